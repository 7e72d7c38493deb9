"""What playback and frame bakes carry from one resolved frame to the next: the garment-to-body
correspondence of an animation's last frame (the thesis' posed pipeline; core searches again
where it drifted), that frame's result (core's ``previous``: what it hid is held a few frames),
and the body's parts read from its groups (reading 160 rig groups costs 0.4 s a frame). One
animation's worth: a new one replaces it."""

from ...core.geometry.cache import Cache

_correspondence = Cache(max_entries=1)
_last_frame = Cache(max_entries=1)
parts = Cache(max_entries=1)


def topology_key(objs, arrays) -> tuple:
    """Which meshes a memory is for: names and vertex and triangle counts."""
    return tuple((o.name, len(a.vertices), len(a.triangles)) for o, a in zip(objs, arrays, strict=True))


def forget() -> None:
    _correspondence.clear()
    _last_frame.clear()
    parts.clear()


def kept_correspondence() -> dict:
    return dict(_correspondence.items())


def keep_correspondence(cache: dict) -> None:
    for key, value in cache.items():
        _correspondence.put(key, value)


def carried(key, frame, step=1) -> dict:
    """core parameters for resolving ``frame`` of the meshes ``key`` after the last frame: on the
    frame next to it (playback; ``step`` frames away or nearer where playback resolves every
    step-th frame), that result and its body points; after a jump (or on a first frame) nothing,
    so the body is searched afresh: a frame looks the same whichever frame one came from, and a
    bake of a range holds what playing it shows."""
    last = _last_frame.get(key)
    if last is None or not 1 <= abs(frame - last[0]) <= step:
        return {}
    params = {"previous": last[1]}
    # body points carried from the last frame; the kept ones fill in for a garment it did not trace
    if key in _correspondence:
        params["correspondence"] = _correspondence.get(key)
    return params


def remember(key, frame, result) -> None:
    """Keep ``result`` of ``frame`` for the next frame: its body points, and the last ones kept
    for a garment this frame did not trace."""
    corr = result.found()[1]
    kept = _correspondence.get(key)
    if kept is None:
        _correspondence.put(key, corr)  # one animation's: the last one's goes
    else:
        _correspondence.put(key, [new if new is not None else c for c, new in zip(kept, corr, strict=True)])
    _last_frame.put(key, (frame, result))
