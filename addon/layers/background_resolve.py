"""One resolve at a time on a worker thread, for viewport playback (While Playing, Resolve in the
Background): on two cores a resolve takes longer than a frame at 24 fps, and run in the frame change
handler it holds the viewport until it ends, so playback falls to about 11 frames a second. Run
beside the viewport, playback keeps its speed and each frame shows the newest finished correction
on its own pose. Only core runs on the thread (resolve_job.compute_resolve touches no bpy); the
scene is read and written on the main thread, in the frame change handler."""

import threading

from . import frame_memory, resolve_job

_running = {"thread": None, "job": None, "box": None}


def busy() -> bool:
    """Whether a resolve runs now."""
    thread = _running["thread"]
    return thread is not None and thread.is_alive()


def start(job: resolve_job.ResolveJob) -> None:
    """Compute ``job`` on a worker thread (none may be running)."""
    if busy():
        raise RuntimeError("a background resolve is still running")
    box = {}

    def run():
        try:
            box["output"] = resolve_job.compute_resolve(job)
        except Exception as exc:  # noqa: BLE001 - handed to the main thread, which reports it
            box["error"] = exc

    thread = threading.Thread(target=run, name="DeformRT resolve", daemon=True)
    _running.update(thread=thread, job=job, box=box)
    thread.start()


def take(wait=False):
    """The last resolve's (job, output) once it has ended (``wait``: wait for it), or None: none ended
    since the last take, or it still runs. Its error, if it failed, is raised here."""
    thread, job, box = _running["thread"], _running["job"], _running["box"]
    if thread is None:
        return None
    if wait:
        thread.join()
    if thread.is_alive():
        return None
    _running.update(thread=None, job=None, box=None)
    if "error" in box:
        raise box["error"]
    return job, box["output"]


def settle() -> None:
    """Wait for a running resolve and keep what it found for the next frame (frame_memory), without
    showing it: the frame playback stops on is resolved on its own (frame_handler)."""
    try:
        done = take(wait=True)
    except Exception:  # noqa: BLE001 - the frame resolved next says what is wrong
        return
    if done is not None:
        job, output = done
        frame_memory.remember(job.key, job.frame, output.result)


def drop() -> None:
    """Wait for a running resolve and forget it (Resolve on Frame Change switched, unregistered)."""
    try:
        take(wait=True)
    except Exception:  # noqa: BLE001 - nothing is shown of a dropped resolve
        pass
