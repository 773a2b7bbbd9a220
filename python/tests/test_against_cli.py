"""Each Python call against the command line on the same input: the same values, rows and
bytes (issue 33's acceptance checks)."""
import shutil

import numpy as np
import pandas as pd
import pytest

import meshgaze


def read_csv(path, **options):
    """pandas' CSV reader with the parser that reads float64 text back exactly."""
    return pd.read_csv(path, **meshgaze.exact_floats(), **options)



def read_map(path):
    table = read_csv(path)
    assert list(table.columns) == ["vertex", "saliency"]
    assert (table["vertex"].to_numpy() == np.arange(len(table))).all()
    return table["saliency"].to_numpy()


@pytest.mark.parametrize("method,seed", [("sms", 7), ("mc", 1)])
def test_saliency_equals_the_cli_csv(cli, repo, tmp_path, method, seed):
    mesh_path = repo / "stimuli" / "meshes" / "bun_zipper_res2.ply"
    mesh = meshgaze.read_mesh(mesh_path)
    assert mesh.vertices.shape == (8171, 3) and mesh.faces.shape[1] == 3
    ours = meshgaze.saliency(mesh, method, seed=seed)
    cli("saliency", mesh_path, "--method", method, "--seed", seed, "-o", tmp_path / method,
        "--quiet")
    theirs = read_map(tmp_path / f"{method}.csv")
    # The CSV prints the shortest text that reads back to the same float64: equality is the
    # printed precision.
    assert ours.dtype == np.float64 and ours.shape == theirs.shape
    assert np.array_equal(ours, theirs), f"max |Δ| {np.abs(ours - theirs).max()}"


def test_sms_seed_changes_the_map_and_repeats_exactly(repo):
    mesh = meshgaze.read_mesh(repo / "stimuli" / "meshes" / "bun_zipper_res3.ply")
    a = meshgaze.saliency(mesh, "sms", seed=7)
    b = meshgaze.saliency(mesh, "sms", seed=7)
    c = meshgaze.saliency(mesh, "sms", seed=8)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_a_mesh_from_arrays_gives_the_files_values(repo):
    mesh = meshgaze.read_mesh(repo / "stimuli" / "meshes" / "bun_zipper_res3.ply")

    class TrimeshLike:  # what trimesh.Trimesh offers: .vertices, .faces
        vertices = mesh.vertices.astype(np.float64)
        faces = mesh.faces.astype(np.int32)

    from_file = meshgaze.saliency(mesh, "mc")
    from_arrays = meshgaze.saliency(TrimeshLike(), "mc")
    assert meshgaze.Mesh(mesh.vertices, mesh.faces).path is None
    assert np.array_equal(from_file, from_arrays)


def test_read_gaze_on_a_real_smi_export_gives_ingests_fixations(cli, shared_data, tmp_path):
    for name in ["hbn-sccn__NDARAA075AMK_Video1_Samples.txt",
                 "hbn-sccn__NDARAA075AMK_Video1_Events.txt"]:
        export = shared_data / "smi" / name
        recording = meshgaze.read_gaze(export)
        out = tmp_path / name
        cli("ingest", export, "-o", out)
        theirs = read_csv(out / "fixations.csv")
        assert len(recording.fixations) > 0, name
        assert len(recording.fixations) == len(theirs), name
        pd.testing.assert_frame_equal(recording.fixations, theirs)
        # Not only the same table: the same bytes ingest wrote.
        assert recording._fixations_csv == (out / "fixations.csv").read_text(), name
        assert list(recording.messages.columns) == list(
            read_csv(out / "messages.csv", keep_default_na=False).columns)


def test_read_gaze_with_a_forced_format_and_a_wrong_one(shared_data):
    export = shared_data / "smi" / "hbn-sccn__NDARAA075AMK_Video1_Samples.txt"
    detected = meshgaze.read_gaze(export)
    forced = meshgaze.read_gaze(export, format="a-begaze")
    assert len(forced.fixations) == len(detected.fixations)
    with pytest.raises(ValueError, match="eyelink"):
        meshgaze.read_gaze(export, format="smi")
    with pytest.raises(meshgaze.MeshgazeError):
        meshgaze.read_gaze(export, format="eyelink")


@pytest.fixture(scope="module")
def pipeline(cli, bunny_dir, tmp_path_factory):
    """The whole chain twice, once by the CLI and once from Python, on the same input:
    stimulus, 4 simulated subjects (format A samples), ingest, project, truth."""
    d = tmp_path_factory.mktemp("pipeline")
    mesh, protocol = bunny_dir / "bunny.ply", bunny_dir / "medium.toml"
    cli("stimulus", mesh, "--protocol", protocol, "-o", d / "cli_stim", "--quiet")
    manifest = meshgaze.render_stimulus(mesh, d / "py_stim", protocol=protocol)
    cli("simulate", "--stimulus", d / "cli_stim", "-o", d / "rec", "--subjects", 4, "--seed", 3)
    samples = sorted((d / "rec").glob("*_samples.txt"))
    cli("ingest", *samples, "-o", d / "cli_ing")
    recording = meshgaze.read_gaze(samples)
    cli("project", "--stimulus", d / "cli_stim", "--fixations", d / "cli_ing" / "fixations.csv",
        "-o", d / "cli_proj", "--quiet")
    projected = meshgaze.project(d / "cli_stim", recording, out_dir=d / "py_proj")
    cli("truth", "--stimulus", d / "cli_stim", d / "cli_proj", "-o", d / "cli_truth", "--quiet")
    truth = meshgaze.build_truth(d / "cli_stim", projected, out_dir=d / "py_truth")
    return {"dir": d, "manifest": manifest, "recording": recording, "projected": projected,
            "truth": truth, "mesh": mesh}


def test_render_stimulus_writes_the_clis_video_and_timeline(pipeline):
    d = pipeline["dir"]
    for name in ["timeline.csv", "stimulus.mp4"]:
        assert (d / "py_stim" / name).read_bytes() == (d / "cli_stim" / name).read_bytes(), name
    m = pipeline["manifest"]
    assert m["video"]["width"] == 320 and m["video"]["height"] == 200
    assert m["video"]["frames"] == 225


def test_render_stimulus_of_a_mesh_from_arrays_writes_it_exactly(bunny_dir, tmp_path):
    mesh = meshgaze.read_mesh(bunny_dir / "bunny.ply")
    arrays = meshgaze.Mesh(mesh.vertices, mesh.faces)
    meshgaze.render_stimulus(arrays, tmp_path / "stim", protocol=bunny_dir / "medium.toml")
    back = meshgaze.read_mesh(tmp_path / "stim" / "mesh.obj")
    assert np.array_equal(back.vertices, mesh.vertices)
    assert np.array_equal(back.faces, mesh.faces)


def test_project_gives_the_clis_projected_csv(pipeline):
    d = pipeline["dir"]
    ours = (d / "py_proj" / "projected.csv").read_bytes()
    assert ours == (d / "cli_proj" / "projected.csv").read_bytes()
    table = pipeline["projected"]
    theirs = read_csv(d / "cli_proj" / "projected.csv", keep_default_na=False, na_values=[""])
    pd.testing.assert_frame_equal(table, theirs)
    assert set(table["fate"]) <= {"hit", "snapped", "background", "off-screen",
                                   "in-transition", "invalid", "filtered"}
    assert (table["fate"] == "hit").sum() > 10
    summary = table.attrs["summary"]
    assert summary["stimulus_name"] == "bunny.mp4" and len(summary["fates"]) == 4


def test_build_truth_gives_the_clis_files(pipeline):
    d = pipeline["dir"]
    for name in ["truth.csv", "density.csv", "human.csv"]:
        assert (d / "py_truth" / name).read_bytes() == (d / "cli_truth" / name).read_bytes(), name
    truth = pipeline["truth"]
    density = read_csv(d / "cli_truth" / "density.csv")
    assert np.array_equal(truth.density, density["density"].to_numpy())
    assert np.array_equal(truth.counts, density["fixations"].to_numpy())
    assert truth.summary["fixations_on_mesh"] == int(truth.counts.sum()) > 10
    assert len(truth.fixations) == len(read_csv(d / "cli_truth" / "truth.csv"))
    human = read_csv(d / "cli_truth" / "human.csv")
    pd.testing.assert_frame_equal(truth.human, human)


def test_score_gives_the_clis_values(cli, pipeline):
    d = pipeline["dir"]
    mesh = meshgaze.read_mesh(pipeline["mesh"])
    cli("saliency", pipeline["mesh"], "--method", "mc", "-o", d / "mc", "--quiet")
    cli("score", "--mesh", pipeline["mesh"], "--truth", d / "cli_truth" / "truth.csv",
        "--saliency", d / "mc.csv", "-o", d / "score", "--quiet")
    theirs = read_csv(d / "score.csv")
    mc = meshgaze.saliency(mesh, "mc")
    for truth in [pipeline["truth"], d / "cli_truth" / "truth.csv"]:
        ours = meshgaze.score(mesh, {"mc": mc}, truth)
        assert list(ours.columns) == ["method", "metric", "blur", "value"]
        merged = ours.merge(theirs, on=["method", "metric", "blur"], suffixes=("", "_cli"))
        assert len(merged) == len(theirs) == len(ours)
        auc0 = merged[(merged.method == "mc") & (merged.metric == "auc_judd") & (merged.blur == 0)]
        assert len(auc0) == 1
        assert auc0["value"].iloc[0] == auc0["value_cli"].iloc[0]
        assert np.array_equal(merged["value"].to_numpy(), merged["value_cli"].to_numpy())
    only = meshgaze.score(mesh, mc, pipeline["truth"], blur=[0.0], metrics=["auc_judd"])
    assert set(only["metric"]) == {"auc_judd"} and set(only["blur"]) == {0.0}


def test_a_study_from_python_writes_the_clis_scores(cli, bunny_dir, tmp_path):
    def make(root):
        (root / "meshes").mkdir(parents=True)
        shutil.copy(bunny_dir / "bunny.ply", root / "meshes" / "bunny.ply")
        shutil.copy(bunny_dir / "medium.toml", root / "medium.toml")
        cli("study", "init", "meshes", "-o", "study.toml", cwd=root)
        text = (root / "study.toml").read_text()
        text = text.replace('# protocol = "my-protocol.toml"', 'protocol = "medium.toml"')
        text = text.replace('methods = ["sms", "mc", "ms", "si", "sri", "mr", "gr"]',
                            'methods = ["mc", "sms"]')
        assert 'protocol = "medium.toml"' in text and 'methods = ["mc", "sms"]' in text
        (root / "study.toml").write_text(text)
        return root / "study.toml"

    ours, theirs = make(tmp_path / "py"), make(tmp_path / "cli")
    study = meshgaze.Study(ours)
    assert study.meshes == ["bunny"] and study.methods == ["mc", "sms"]
    study.run(jobs=1)  # renders the stimulus; no recordings yet
    cli("study", "run", theirs, "--quiet")
    for root in [tmp_path / "py", tmp_path / "cli"]:
        cli("simulate", "--study", root / "study.toml", "-o", root / "recordings",
            "--subjects", 3, "--seed", 5)
    account = study.run(jobs=2)
    cli("study", "run", theirs, "--jobs", 2, "--quiet")
    assert not [s for s in account["steps"] if s["outcome"] == "failed"], account["steps"]
    scores = study.scores()
    assert set(scores["method"]) >= {"mc", "sms"}
    assert (tmp_path / "py" / "study" / "scores.csv").read_bytes() == \
        (tmp_path / "cli" / "study" / "scores.csv").read_bytes()
    again = meshgaze.Study(ours).run()
    assert {s["outcome"] for s in again["steps"]} <= {"up-to-date", "skipped"}


def test_view_writes_the_clis_page(cli, pipeline):
    d = pipeline["dir"]
    mesh = meshgaze.read_mesh(pipeline["mesh"])
    mc = meshgaze.saliency(mesh, "mc")
    cli("saliency", pipeline["mesh"], "--method", "mc", "-o", d / "view_mc", "--quiet")
    cli("view", pipeline["mesh"], "--saliency", f"mc={d / 'view_mc.csv'}", "--truth",
        d / "cli_truth", "--stimulus", d / "cli_stim", "-o", d / "cli_view.html", "--quiet")
    path = meshgaze.view(mesh, d / "py_view.html", maps={"mc": mc}, truth=pipeline["truth"],
                         stimulus=d / "cli_stim")
    ours = open(path, "rb").read()
    assert ours == (d / "cli_view.html").read_bytes()
    text = ours.decode()
    assert "http://" not in text and "https://" not in text
    # A projection DataFrame gives its fixations too, and a mesh that is not the stimulus's
    # is refused.
    meshgaze.view(mesh, d / "py_view2.html", fixations=pipeline["projected"], stimulus=d / "cli_stim")
    with pytest.raises(meshgaze.MeshgazeError, match="another mesh"):
        small = meshgaze.Mesh(mesh.vertices[:3], np.array([[0, 1, 2]]))
        meshgaze.view(small, d / "bad.html", stimulus=d / "cli_stim")


def test_score_reads_a_per_face_truth_as_the_cli_does(cli, repo, tmp_path):
    mesh_path = repo / "stimuli" / "meshes" / "bun_zipper_res3.ply"
    mesh = meshgaze.read_mesh(mesh_path)
    heights = mesh.vertices[mesh.faces].mean(axis=1)[:, 1]  # one value per face
    faces = tmp_path / "faces.csv"
    faces.write_text("face,value\n" + "".join(f"{i},{float(v)!r}\n" for i, v in enumerate(heights)))
    mc = meshgaze.saliency(mesh, "mc")
    cli("saliency", mesh_path, "--method", "mc", "-o", tmp_path / "mc", "--quiet")
    cli("score", "--mesh", mesh_path, "--truth", faces, "--saliency", tmp_path / "mc.csv",
        "-o", tmp_path / "score", "--quiet", "--borji-splits", 5)
    theirs = read_csv(tmp_path / "score.csv")
    ours = meshgaze.score(mesh, {"mc": mc}, faces, borji_splits=5)
    merged = ours.merge(theirs, on=["method", "metric", "blur"], suffixes=("", "_cli"))
    assert len(merged) == len(ours) == len(theirs)
    assert np.array_equal(merged["value"].to_numpy(), merged["value_cli"].to_numpy())
    with pytest.raises(meshgaze.MeshgazeError, match="faces.csv"):
        meshgaze.score(mesh, {"mc": mc}, faces, truth_layout="vertex")


def test_saliency_up_axis_equals_the_cli_and_moves_the_gaze_map(cli, repo, tmp_path):
    mesh_path = repo / "stimuli" / "meshes" / "bun_zipper_res3.ply"
    mesh = meshgaze.read_mesh(mesh_path)
    ours = meshgaze.saliency(mesh, "gaze", up="z")
    cli("saliency", mesh_path, "--method", "gaze", "--up", "z", "-o", tmp_path / "gaze_z",
        "--quiet")
    assert np.array_equal(ours, read_map(tmp_path / "gaze_z.csv"))
    assert not np.array_equal(ours, meshgaze.saliency(mesh, "gaze"))
    with pytest.raises(ValueError, match="up"):
        meshgaze.saliency(mesh, "gaze", up="w")
