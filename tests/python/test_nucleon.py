"""`import nucleon`: the Python bindings against the C++ world and the command line.

Run by ctest (test `python_bindings`) with PYTHONPATH at the built module."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import nucleon

ASSETS = os.environ.get("NUCLEON_ASSETS", os.path.join(os.path.dirname(__file__), "../../assets"))
HANG = os.path.join(ASSETS, "scenes", "cloth_hang.json")


def test_positions_are_a_read_only_view_that_follows_the_world():
    world = nucleon.World.from_scene(HANG)
    x = world.positions()
    assert x.shape == (4096, 3) and x.dtype == nucleon.real
    assert not x.flags.writeable and not x.flags.owndata  # a view of the pool, not a copy
    before = x[4095].copy()
    world.step()
    assert not np.array_equal(x[4095], before)  # the same view sees the step
    with pytest.raises(ValueError):
        x[0, 0] = 1.0
    assert world.positions("cloth").shape == (4096, 3)


def test_same_state_as_the_command_line():
    # The bindings step the same world as `nucleon run`: equal state hashes.
    world = nucleon.World.from_scene(HANG, set=["solver.iterations=4"])
    world.step(count=5)
    program = os.environ.get("NUCLEON_PROGRAM")
    if program is None:
        pytest.skip("NUCLEON_PROGRAM not set")
    out = subprocess.run([program, "run", HANG, "--quiet", "--frames", "5", "--set",
                          "solver.iterations=4"], check=True, capture_output=True, text=True).stdout
    assert "state %016x" % world.state_hash() in out


def test_scene_from_a_dict_falls_as_symplectic_euler():
    scene = {
        "name": "free", "fps": 60, "gravity": [0, -9.81, 0],
        "solver": {"type": "colored-gs", "iterations": 4, "substeps": 2},
        "objects": [{"type": "cloth", "name": "sheet",
                     "shape": {"grid": {"resolution": [8, 8], "size": [1, 1], "center": [0, 5, 0]}},
                     "material": {"mass": 1.0}}],
    }
    world = nucleon.World.from_dict(scene)
    world.step(count=30)
    n, h = 60, 1 / 120  # 30 frames of 2 substeps
    fell = 5 - world.positions("sheet")[:, 1].mean()
    assert fell == pytest.approx(9.81 * h * h * n * (n + 1) / 2, rel=1e-4)


def test_remove_object_leaves_the_rest_falling():
    scene = {
        "name": "two", "fps": 60, "gravity": [0, -9.81, 0],
        "solver": {"type": "colored-gs", "iterations": 4, "substeps": 2},
        "objects": [{"type": "cloth", "name": name,
                     "shape": {"grid": {"resolution": [8, 8], "size": [1, 1],
                                        "center": [x, 5, 0]}},
                     "material": {"mass": 1.0}} for name, x in (("a", 0), ("b", 5))],
    }
    world = nucleon.World.from_dict(scene)
    world.step(count=10)
    assert world.remove_object("a") == 0
    assert world.object_names == ["b"] and world.particle_count == 64
    with pytest.raises(KeyError):
        world.positions("a")
    world.step(count=20)
    n, h = 60, 1 / 120  # b fell free all along: 30 frames of 2 substeps
    fell = 5 - world.positions("b")[:, 1].mean()
    assert fell == pytest.approx(9.81 * h * h * n * (n + 1) / 2, rel=1e-4)


def test_writes_impulses_and_drags():
    world = nucleon.World.from_scene(HANG)
    world.step(count=3)
    n = world.positions("cloth").shape[0]
    lifted = np.ascontiguousarray(world.positions("cloth") + np.array([0, 1, 0], nucleon.real))
    world.set_positions("cloth", lifted)
    assert np.array_equal(world.positions("cloth"), lifted)
    world.set_velocities("cloth", np.zeros((n, 3), nucleon.real))
    assert not world.velocities("cloth").any()
    world.apply_impulse("cloth", [0.0, 0.0, 0.5])
    v = world.velocities("cloth").astype(np.float64)
    w = world.inverse_masses()[:n].astype(np.float64)
    free = w > 0
    assert free.sum() == n - 2  # the two pins do not move
    # The object's momentum grows by exactly J, shared as one velocity (no deformation).
    momentum = (v[free] / w[free, None]).sum(axis=0)
    assert momentum == pytest.approx([0, 0, 0.5], abs=1e-5)
    assert np.ptp(v[free, 2]) == 0
    drag = world.begin_drag("cloth", 4095, [0.5, 0.5, 0.5], compliance=0.0)
    world.step(count=20)
    assert np.linalg.norm(world.positions("cloth")[4095] - [0.5, 0.5, 0.5]) < 1e-3
    world.end_drag(drag)
    with pytest.raises(ValueError):
        world.set_positions("cloth", np.zeros((3, 3), nucleon.real))
    with pytest.raises(KeyError):
        world.positions("no such object")


def test_checkpoint_resumes_to_the_same_state(tmp_path):
    world = nucleon.World.from_scene(HANG)
    world.step(count=5)
    path = str(tmp_path / "five.ckpt")
    world.save_checkpoint(path)
    world.step(count=5)
    resumed = nucleon.World.from_scene(HANG)
    resumed.load_checkpoint(path)
    assert resumed.steps == 5
    resumed.step(count=5)
    assert resumed.state_hash() == world.state_hash()
    with pytest.raises(RuntimeError, match="another scene or settings"):
        nucleon.World.from_scene(HANG).load_checkpoint(path, label="other")


def test_constraint_written_in_python_holds_a_corner_on_a_plane():
    world = nucleon.World.from_scene(HANG, set=["solver.type=gauss-seidel", "solver.iterations=10"])
    normal = np.array([0, 1, 0], nucleon.real)

    def on_plane(x, rest):  # C = n·x − d, ∇C = n
        return float(normal @ x[0] - rest[0]), normal.reshape(1, 3)

    family = world.register_constraint("on-plane", 1, 1, on_plane)
    world.add_constraint("cloth", family, [4095], [0.8])
    world.step(count=30)
    assert world.positions("cloth")[4095, 1] == pytest.approx(0.8, abs=1e-4)

    def broken(x, rest):
        raise ValueError("no")

    other = world.register_constraint("broken", 1, 1, broken)
    world.add_constraint("cloth", other, [100], [0.0])
    with pytest.raises(RuntimeError, match="constraint function raised"):
        world.step()


def test_bad_scenes_raise_with_the_file_named():
    with pytest.raises(RuntimeError, match="no such scene file"):
        nucleon.World.from_scene("/nonexistent/scene.json")
    with pytest.raises(RuntimeError, match="sweeps"):
        nucleon.World.from_scene(HANG, set=["solver.sweeps=3"])


def test_example_script_runs():
    example = os.path.join(os.environ.get("NUCLEON_EXAMPLES", "examples"), "strain_plot.py")
    out = subprocess.run([sys.executable, example, HANG, "--frames", "6", "--no-plot"],
                         check=True, capture_output=True, text=True).stdout
    rows = [line for line in out.splitlines() if line.startswith("frame")]
    assert len(rows) == 6
