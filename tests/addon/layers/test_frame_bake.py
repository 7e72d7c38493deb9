"""Bake Frames stops when asked (Ctrl+C, SIGTERM, Esc) with nothing written and the scene as it was,
and a bake with Resolve on Frame Change off leaves the still resolve shown."""

import os
import signal
import subprocess
import sys
import textwrap

import bpy
import numpy as np
import pytest

from tests.addon.layers.test_resolve_ops import evaluated, sub


def _sending_on_the_third(monkeypatch, handler, sig):
    correct, calls = handler.correct_frame, []

    def correct_then_signal(scene, step=1):
        calls.append(scene.frame_current)
        out = correct(scene, step)
        if len(calls) == 3:
            os.kill(os.getpid(), sig)
        return out

    monkeypatch.setattr(handler, "correct_frame", correct_then_signal)
    return calls


def test_ctrl_c_stops_a_bake_between_frames_and_nothing_is_written(extension, tubes, tmp_path, monkeypatch):
    """Ctrl+C during the third of six frames: the bake ends there (it used to be swallowed by a
    handler and the bake ran on and replaced the cache), the earlier cache stays byte for byte,
    no partial file, Python's own Ctrl+C handling is back, and the still resolve shown before is."""
    body, garments = tubes
    handler = sub(extension, "addon.layers.frame_handler")
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    shown = [evaluated(o)[0] for o in (body, *garments)]
    path = tmp_path / "layers.abc"
    assert bpy.ops.deformrt.bake_frames(frame_start=1, frame_end=2, filepath=str(path)) == {"FINISHED"}
    earlier = path.read_bytes()
    before = signal.getsignal(signal.SIGINT)
    calls = _sending_on_the_third(monkeypatch, handler, signal.SIGINT)
    with pytest.raises(RuntimeError, match="Bake stopped after 3 of 6 frames, nothing written.*SIGINT"):
        bpy.ops.deformrt.bake_frames(frame_start=1, frame_end=6, filepath=str(path))
    assert calls == [1, 2, 3]
    assert path.read_bytes() == earlier and sorted(p.name for p in tmp_path.iterdir()) == ["layers.abc"]
    assert signal.getsignal(signal.SIGINT) is before
    assert bpy.context.scene.frame_current == 1 and not bpy.context.scene.deformrt.resolve_on_frame_change
    for o, v in zip((body, *garments), shown, strict=True):
        np.testing.assert_allclose(evaluated(o)[0], v, atol=1e-6)


def test_ctrl_c_while_the_cache_is_written_leaves_no_file(extension, tubes, tmp_path, monkeypatch):
    """Ctrl+C once every frame is resolved, while Blender's exporter writes: the frames after it
    are not written, and the file it was writing goes."""
    handler = sub(extension, "addon.layers.frame_handler")
    results = sub(extension, "addon.layers.results")
    write, written = results.write, []

    def write_then_signal(*args, **kwargs):
        if handler._replay is not None:
            written.append(bpy.context.scene.frame_current)
            if len(written) == 4:  # the exporter's first frame (the first three: the frame set before it)
                os.kill(os.getpid(), signal.SIGINT)
        return write(*args, **kwargs)

    monkeypatch.setattr(results, "write", write_then_signal)
    path = tmp_path / "layers.abc"
    with pytest.raises(RuntimeError, match="Bake stopped after 4 of 4 frames, nothing written.*SIGINT"):
        bpy.ops.deformrt.bake_frames(frame_start=1, frame_end=4, filepath=str(path))
    assert len(written) == 6 and list(tmp_path.iterdir()) == []  # that frame's three objects, then none


def test_a_bake_with_resolve_on_frame_change_off_keeps_the_still_resolve(extension, tubes, tmp_path):
    """Baking used to switch the handler on and off, which cleared the resolve the user had made:
    F12 showed the poke-through again. The resolve shown before is shown after."""
    body, garments = tubes
    fitted = [evaluated(o)[0] for o in garments]
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    shown = [evaluated(o)[0] for o in (body, *garments)]
    assert max(np.abs(s - f).max() for s, f in zip(shown[1:], fitted, strict=True)) > 1e-3
    assert bpy.ops.deformrt.bake_frames(frame_start=1, frame_end=3, filepath=str(tmp_path / "a.abc")) == {"FINISHED"}
    for o, v in zip((body, *garments), shown, strict=True):
        np.testing.assert_allclose(evaluated(o)[0], v, atol=1e-6)


def test_esc_abandons_the_bake_where_it_is(extension, tubes, tmp_path):
    """What Esc does in the UI (the modal bake resolves a frame per timer tick): two of five frames
    resolved, then abandoned: no file, the frame and the still resolve as they were."""
    body, garments = tubes
    fb = sub(extension, "addon.layers.frame_bake")
    scene = bpy.context.scene
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    shown = [evaluated(o)[0] for o in (body, *garments)]
    scene.frame_set(4)
    bake = fb.FrameBake(scene, body, list(garments), range(1, 6), str(tmp_path / "b.abc"))
    assert bake.step() and bake.step() and bake.done == 2 and scene.frame_current == 2
    bake.abandon()
    assert scene.frame_current == 4 and list(tmp_path.iterdir()) == []
    for o, v in zip((body, *garments), shown, strict=True):
        np.testing.assert_allclose(evaluated(o)[0], v, atol=1e-6)


_TERMINATED = textwrap.dedent("""
    import os, signal, sys
    from pathlib import Path
    import bpy, importlib
    zip_path, out = sys.argv[1], Path(sys.argv[2])
    repo_dir = Path(os.environ["BLENDER_USER_RESOURCES"]) / "repo"
    repo_dir.mkdir(parents=True)
    repo = bpy.context.preferences.extensions.repos.new(name="T", module="t", custom_directory=str(repo_dir),
                                                        source="USER")
    bpy.ops.extensions.package_install_files(repo="t", filepath=zip_path, enable_on_install=True)
    ext = "bl_ext.t.deformrt"
    importlib.import_module(ext + ".sample_scenes.tubes").build(seed=0, resolution=24)
    path = str(out / "layers.abc")
    assert bpy.ops.deformrt.bake_frames(frame_start=1, frame_end=2, filepath=path) == {"FINISHED"}
    print("earlier", os.path.getsize(path), flush=True)
    handler = importlib.import_module(ext + ".addon.layers.frame_handler")
    correct = handler.correct_frame
    def terminated_on_the_second(scene, step=1):
        out = correct(scene, step)
        if scene.frame_current == 2:
            os.kill(os.getpid(), signal.SIGTERM)
        return out
    handler.correct_frame = terminated_on_the_second
    bpy.ops.deformrt.bake_frames(frame_start=1, frame_end=20, filepath=path)
    print("not stopped", flush=True)
""")


def test_sigterm_ends_the_process_after_the_bake_cleaned_up(extension_zip, tmp_path):
    """A pipeline's SIGTERM mid-bake: the process still ends by SIGTERM, but only after the partial
    file went and the earlier cache was left as it was (before, the bake ran on and a
    .deformrt-partial.abc stayed)."""
    script = tmp_path / "bake.py"
    script.write_text(_TERMINATED)
    out = tmp_path / "out"
    out.mkdir()
    # its own Blender user folder under tmp_path, which pytest removes (the process ends by SIGTERM,
    # so it cannot clean up after itself)
    env = {**os.environ, "BLENDER_USER_RESOURCES": str(tmp_path / "user")}
    run = subprocess.run([sys.executable, str(script), str(extension_zip), str(out)], capture_output=True,
                         text=True, timeout=300, env=env)
    assert run.returncode == -signal.SIGTERM, run.stdout + run.stderr
    assert "not stopped" not in run.stdout and "Bake stopped after 2 of 20 frames" in run.stdout + run.stderr
    earlier = int(run.stdout.split("earlier ")[1].split()[0])
    assert [p.name for p in out.iterdir()] == ["layers.abc"] and (out / "layers.abc").stat().st_size == earlier
