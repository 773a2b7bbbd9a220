"""Bad input from Python: the library's message (file, line) as a MeshgazeError or a
ValueError, never a crash and never a silent result."""
import numpy as np
import pytest

import meshgaze


def test_a_missing_mesh_names_its_path(tmp_path):
    missing = tmp_path / "nope.ply"
    with pytest.raises(meshgaze.MeshgazeError, match="nope.ply"):
        meshgaze.read_mesh(missing)


def test_a_malformed_mesh_says_where(tmp_path):
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n")
    with pytest.raises(meshgaze.MeshgazeError, match=r"bad.obj.*4"):
        meshgaze.read_mesh(bad)


def test_arrays_of_the_wrong_shape_or_range_are_refused():
    v = np.zeros((3, 3))
    with pytest.raises(ValueError, match="shape"):
        meshgaze.Mesh(np.zeros((3, 2)), np.array([[0, 1, 2]]))
    with pytest.raises(ValueError, match="vertex 3"):
        meshgaze.Mesh(v, np.array([[0, 1, 3]]))
    with pytest.raises(ValueError, match="not finite"):
        meshgaze.Mesh(np.array([[0, 0, np.nan], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))


def test_unknown_methods_and_keywords_are_refused(repo):
    mesh = meshgaze.read_mesh(repo / "stimuli" / "meshes" / "bun_zipper_res3.ply")
    with pytest.raises(ValueError, match="sms, mc"):
        meshgaze.saliency(mesh, "nope")
    with pytest.raises(TypeError, match="samples"):
        meshgaze.saliency(mesh, "sms", sample=10)
    # An SMS parameter given to another method would be silently unused: refused.
    with pytest.raises(TypeError, match="SMS parameter"):
        meshgaze.saliency(mesh, "mc", samples=10)


def test_a_map_of_the_wrong_length_is_refused(repo):
    mesh = meshgaze.read_mesh(repo / "stimuli" / "meshes" / "bun_zipper_res3.ply")
    n = len(mesh.vertices)
    with pytest.raises(ValueError, match="vertices"):
        meshgaze.score(mesh, np.zeros(n - 1), np.ones(n))
    with pytest.raises(ValueError, match="blur"):
        meshgaze.score(mesh, np.zeros(n), np.ones(n), blur=[-1.0])


def test_a_file_that_is_no_recording_says_so(tmp_path):
    bad = tmp_path / "notes.txt"
    bad.write_text("shopping list\neggs\n")
    with pytest.raises(meshgaze.MeshgazeError, match="notes.txt"):
        meshgaze.read_gaze(bad)


def test_a_stimulus_folder_without_manifest_is_refused(tmp_path):
    with pytest.raises(meshgaze.MeshgazeError, match="manifest"):
        meshgaze.project(tmp_path, [tmp_path / "fixations.csv"])


def test_every_public_call_is_documented():
    for name in meshgaze.__all__:
        obj = getattr(meshgaze, name)
        if name == "METHODS":
            continue
        assert obj.__doc__ and len(obj.__doc__) > 40, name
