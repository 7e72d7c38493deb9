"""The baked swim's rise follows the simulated path cycle after cycle, and repeats the last cycle after."""

import numpy as np
import pytest

from core.jellyfish import default_config, default_creature, one_cycle, simulate_cycles
from core.jellyfish.keyframes import BellPose, FrameRange, swim_frames


@pytest.fixture(scope="module")
def run():
    cfg = default_config(particles=40)
    return cfg, simulate_cycles(default_creature(cfg), cfg, 3, sample_fields=True)


def _rises(cfg, run, frames, cycle_frames):
    rest = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    zero = np.zeros_like(rest)
    out = swim_frames(run, default_creature(cfg), FrameRange(1, frames, cycle_frames),
                      BellPose(rest, zero, zero, faces, zero, 1.0))
    return np.array([f.rise_m for f in out])


def test_each_cycle_boundary_is_at_the_path_swum_so_far(run):
    cfg, r = run
    rise = _rises(cfg, r, 1 + 5 * cfg.substeps, cfg.substeps)  # a frame a substep, five cycles
    ends = np.cumsum(r.path_per_cycle_m)
    np.testing.assert_allclose(rise[cfg.substeps::cfg.substeps][:3], ends, rtol=1e-12)
    np.testing.assert_allclose(rise[1:1 + 3 * cfg.substeps], r.swum, rtol=1e-12)
    # past the simulated three, the last cycle repeats: cycles 4 and 5 each swim the third's path
    np.testing.assert_allclose(np.diff(rise[3 * cfg.substeps::cfg.substeps]), r.path_per_cycle_m[2], rtol=1e-12)


def test_one_cycle_of_a_run_is_that_cycle_from_its_start(run):
    cfg, r = run
    second = one_cycle(r, 1)
    assert second.path_m == r.path_per_cycle_m[1] and second.swum[-1] == pytest.approx(second.path_m, rel=1e-12)
    assert len(second.fields) == cfg.substeps
    times = [t for t, *_ in second.fields]
    np.testing.assert_allclose(times, np.arange(1, cfg.substeps + 1) * cfg.period / cfg.substeps)
    with pytest.raises(ValueError, match="cycle 3"):
        one_cycle(r, 3)
