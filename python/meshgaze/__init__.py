"""meshgaze from Python: mesh saliency, gaze recordings, stimuli, projection, ground truth and
scoring, as numpy arrays and pandas DataFrames.

Every call is a thin wrapper over the meshgaze Rust library, calling the function the
`meshgaze` command line calls, so the values and files are the ones the CLI writes:

>>> import meshgaze
>>> mesh = meshgaze.read_mesh("bunny.ply")
>>> sms = meshgaze.saliency(mesh, "sms", seed=7)            # numpy (n,)
>>> rec = meshgaze.read_gaze("s01_samples.txt")             # rec.fixations: DataFrame
>>> meshgaze.render_stimulus(mesh, "stim")                   # stimulus.mp4, timeline.csv
>>> proj = meshgaze.project("stim", rec, out_dir="proj")    # projected fixations
>>> truth = meshgaze.build_truth("stim", [proj])             # fixation-set ground truth
>>> meshgaze.score(mesh, {"sms": sms}, truth)                # method, metric, blur, value

The computation runs with the GIL released; bad input raises MeshgazeError (or ValueError /
TypeError for a bad argument) with the CLI's message, naming file, line and column.
"""
from __future__ import annotations

import io
import json
import os
import tempfile
from typing import TYPE_CHECKING, Any, Iterable, Mapping, Sequence, Union

import numpy as np

from . import _meshgaze
from ._meshgaze import Mesh, MeshgazeError, read_mesh

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "Mesh", "MeshgazeError", "read_mesh", "saliency", "read_gaze", "Recording", "score",
    "render_stimulus", "project", "build_truth", "Truth", "Study", "view", "METHODS",
]
__version__: str = _meshgaze.version()

#: Every saliency method `saliency` computes (the paper's seven, then three viewing priors).
METHODS = ("sms", "mc", "ms", "si", "sri", "mr", "gr", "up", "centre", "gaze")

PathLike = Union[str, bytes, "os.PathLike[str]"]
#: A Mesh, a path to a mesh file, or any object with `.vertices` (n, 3) and `.faces` (m, 3),
#: such as trimesh.Trimesh.
MeshLike = Any


def _pandas():
    # pandas is imported on first use: `import meshgaze` for saliency alone then costs what
    # numpy costs, not the ~0.3 s pandas adds to a short script.
    import pandas
    return pandas


def _read_csv(source, **options):
    return _pandas().read_csv(source, **exact_floats(), **options)


def exact_floats() -> dict:
    """read_csv options that read the CSVs' shortest float64 text back to the same float64.
    pandas 2's default "high" parser can be one unit in the last place off; pandas 3 reads
    exactly by default and deprecates the option."""
    major = int(_pandas().__version__.split(".")[0])
    return {"float_precision": "round_trip"} if major < 3 else {}


def _is_path(x: object) -> bool:
    return isinstance(x, (str, bytes)) or hasattr(x, "__fspath__")


def _path_or_none(p: PathLike | None) -> str | None:
    return None if p is None else os.fsdecode(p)


def _as_mesh(mesh: MeshLike) -> Mesh:
    if isinstance(mesh, Mesh):
        return mesh
    if _is_path(mesh):
        return read_mesh(os.fsdecode(mesh))
    # trimesh, open3d-converted or any object with vertices and faces
    return Mesh(np.ascontiguousarray(mesh.vertices, dtype=np.float64),
                np.ascontiguousarray(mesh.faces, dtype=np.int64))


def saliency(mesh: MeshLike, method: str = "sms", seed: int = 1, *,
             settings: Sequence[str] = (), protocol: PathLike | None = None,
             up: str | None = None, model: PathLike | None = None, progress: bool = False,
             **params: Any) -> np.ndarray:
    """Per-vertex saliency in [0, 1], the values `meshgaze saliency --method METHOD --seed
    SEED` writes (equal as float64, not merely close).

    method: one of METHODS. seed: the random seed (the CLI's default is 1).
    SMS keywords (the paper's defaults when unset): samples, mu, sigma, scales, shells, bands,
    quadrature_rings, grid, gedt_sigma_voxels, max_iterations, tolerance.
    settings: parameters of sri, gr and mr as `--set` takes them, e.g. ["sri.most_similar=32"].
    protocol: the protocol file for up, centre and gaze (default: the built-in hu2020).
    up: the axis the mesh stores as up, as the subjects saw it ("x", "y", "z", "neg-x",
    "neg-y", "neg-z"; default: the protocol's, +y): `meshgaze saliency --up`. The gaze model
    reads height and facing along it, and is below curvature on meshes turned from +y up.
    model: a model file from `meshgaze train`, for method="gaze" (default: the built-in one,
    learned from one VR experiment; check it on your own data with `meshgaze train --cv`).
    progress: print the steps on stderr.
    """
    return _meshgaze.saliency(_as_mesh(mesh), method, seed, settings=list(settings),
                              protocol=_path_or_none(protocol), up=up,
                              model=_path_or_none(model),
                              progress=progress, **params)


class Recording:
    """Eye-tracker recordings read as `meshgaze ingest` reads them.

    fixations, messages, quality: DataFrames with the columns of ingest's fixations.csv,
    messages.csv and quality.csv (parsed from the very text ingest writes); samples: the
    samples.csv table when read_gaze(..., samples=True), else None; files: one dict per file
    (path, subject, fixations, notes: what the reader noticed or skipped, with counts).
    """

    fixations: pd.DataFrame
    messages: pd.DataFrame
    quality: pd.DataFrame
    samples: pd.DataFrame | None
    files: list[dict]

    def __init__(self, tables: Mapping[str, Any]):
        self._fixations_csv: str = tables["fixations"]
        self.fixations = _read_csv(io.StringIO(tables["fixations"]))
        self.messages = _read_csv(io.StringIO(tables["messages"]), keep_default_na=False)
        self.quality = _read_csv(io.StringIO(tables["quality"]))
        s = tables["samples"]
        self.samples = _read_csv(io.StringIO(s)) if s is not None else None
        self.files = [
            {"path": p, "subject": sub, "fixations": n, "notes": notes}
            for p, sub, n, notes in tables["files"]
        ]

    def __repr__(self) -> str:
        return f"Recording({len(self.files)} files, {len(self.fixations)} fixations)"


def read_gaze(paths: PathLike | Iterable[PathLike], **ingest_options: Any) -> Recording:
    """Read eye-tracker recordings as `meshgaze ingest` does: SMI (iView X, BeGaze), EyeLink
    ASC, Tobii Pro Lab / Studio / Pro SDK, Pupil Labs (Core surfaces, Cloud), Gazepoint;
    the format is detected from the content.

    Options (ingest's flags): protocol (sets the fixation filter and the screen), format
    (force one: a, a-begaze, c1, c2, b, b-fix, a2, eyelink, tobii-pro-lab, tobii-studio,
    tobii-studio-list, tobii-sdk, gazepoint, pupil-core, pupil-cloud), detector, eye,
    validity, subject, screen=(width, height) in pixels, stimulus_pattern and
    stimulus_end_pattern (regular expressions with one group around the video name),
    max_dispersion_px, min_duration_ms, max_velocity_deg_s, samples=True for the sample table.
    """
    if _is_path(paths):
        paths = [paths]
    return Recording(_meshgaze.read_gaze([os.fsdecode(p) for p in paths], **ingest_options))


def score(mesh: MeshLike, saliency: np.ndarray | Mapping[str, np.ndarray],
          truth: np.ndarray | PathLike | Truth, blur: Sequence[float] | None = None,
          metrics: Iterable[str] | None = None, **options: Any) -> pd.DataFrame:
    """Score per-vertex maps against human truth as `meshgaze score` does.

    saliency: one array (named "map") or a dict name -> array, one value per vertex.
    truth: an array (one value per vertex; its top `top_fraction` are the positives), a truth
    file (any format `meshgaze score --truth` reads) or a Truth from build_truth.
    blur: the σ_b scales (default: the CLI's 0, 0.01, ..., 0.2). metrics: keep only these
    (auc_judd, auc_borji, lcc, nss, sim, kl, gini, auc_judd_visible).
    Options: seed, kernel (euclidean, gaussian, heat), weighting (vertex, area), top_fraction,
    borji_splits, protocol (its hold views decide auc_judd_visible; default the built-in
    one), truth_layout for a truth file (auto, vertex, face: a per-face map is carried to
    vertices by the area-weighted mean of each vertex's faces), progress.

    Returns a DataFrame with columns method, metric, blur, value; the rows include the chance
    band (chance, chance_p2.5, chance_p97.5) and, for a fixation truth with several subjects,
    the split-half human ceiling (method "human").
    """
    mesh = _as_mesh(mesh)
    if isinstance(saliency, Mapping):
        maps = [(str(k), np.ascontiguousarray(v, dtype=np.float64)) for k, v in saliency.items()]
    else:
        maps = [("map", np.ascontiguousarray(saliency, dtype=np.float64))]
    blur = None if blur is None else [float(b) for b in blur]
    if isinstance(truth, Truth):
        rows, _ = _meshgaze.score(mesh, maps, truth=truth._inner, blur=blur, **options)
    elif _is_path(truth):
        rows, _ = _meshgaze.score(mesh, maps, truth_path=os.fsdecode(truth), blur=blur,
                                  **options)
    else:
        values = np.ascontiguousarray(truth, dtype=np.float64)
        rows, _ = _meshgaze.score(mesh, maps, truth_values=values, blur=blur, **options)
    table = _pandas().DataFrame(rows, columns=["method", "metric", "blur", "value"])
    if metrics is not None:
        table = table[table["metric"].isin(list(metrics))].reset_index(drop=True)
    return table


def render_stimulus(mesh: MeshLike, out_dir: PathLike, protocol: PathLike | None = None,
                    frames: str = "none", id_buffer: bool = False, verify: bool = False,
                    progress: bool = False) -> dict:
    """Render the turntable stimulus of a mesh into out_dir, as `meshgaze stimulus`:
    stimulus.mp4 (H.264), timeline.csv (the camera of every frame) and manifest.json.

    mesh: a Mesh, a path or a trimesh-like object; one made from arrays is written to
    out_dir/mesh.obj first (exact coordinates), the file the manifest hashes.
    protocol: the protocol file (default: the built-in hu2020, the paper's 48 s video).
    frames: also write PNG frames: "keyframes" (first of every hold) or "all".
    id_buffer: also write triangle-id images of the keyframes. verify: decode the video back
    and compare. Returns the manifest as a dict.
    """
    mesh = _as_mesh(mesh)
    text = _meshgaze.render_stimulus(mesh, os.fsdecode(out_dir),
                                     protocol=_path_or_none(protocol), frames=frames,
                                     id_buffer=id_buffer, verify=verify, progress=progress)
    return json.loads(text)


def _fixation_files(fixations: Any, scratch: str) -> list[str]:
    """Paths of fixations.csv files for `fixations`: paths as they are, Recordings written to
    scratch (the CSV text `ingest` would write)."""
    if _is_path(fixations) or isinstance(fixations, Recording):
        fixations = [fixations]
    files = []
    for i, f in enumerate(fixations):
        if isinstance(f, Recording):
            path = os.path.join(scratch, f"recording-{i}", "fixations.csv")
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "w", encoding="utf-8", newline="") as out:
                out.write(f._fixations_csv)
            files.append(path)
        elif _is_path(f):
            files.append(os.fsdecode(f))
        else:
            raise TypeError(f"fixations: expected paths or Recordings, not {type(f).__name__}")
    return files


def project(stimulus: PathLike, fixations: Any, out_dir: PathLike | None = None,
            **options: Any) -> pd.DataFrame:
    """Project 2D fixations onto the mesh of a rendered stimulus, as `meshgaze project`.

    stimulus: the stimulus folder (or its manifest.json). fixations: fixations.csv paths from
    `meshgaze ingest`, Recordings from read_gaze, or a list of either.
    Options: stimulus_name, onset_us, screen=(width, height), during_move (mid, start,
    reject), snap, snap_deg, cone_deg, mesh (if it moved since rendering), targets
    (simulate's targets.csv, for the round-trip check), self_check, progress.

    Returns a DataFrame with projected.csv's columns, one row per fixation with its fate (hit,
    snapped, background, off-screen, in-transition, invalid, filtered: misses are rows, not
    gaps). attrs["summary"] is project.json as a dict; with out_dir the files are written
    there too and attrs["path"] names projected.csv, which build_truth reads.
    """
    with tempfile.TemporaryDirectory(prefix="meshgaze-") as scratch:
        files = _fixation_files(fixations, scratch)
        text, summary = _meshgaze.project(os.fsdecode(stimulus), files,
                                          out_dir=_path_or_none(out_dir), **options)
    table = _read_csv(io.StringIO(text), keep_default_na=False, na_values=[""])
    table.attrs["summary"] = json.loads(summary)
    table.attrs["csv"] = text
    if out_dir is not None:
        table.attrs["path"] = os.path.join(os.fsdecode(out_dir), "projected.csv")
    return table


class Truth:
    """A mesh's ground truth from build_truth; pass it to `score` as the truth.

    fixations: truth.csv as a DataFrame (every fixation, its fate, vertex and surface point);
    counts, density: per-vertex numpy arrays (density.csv); cone: the cone density or None;
    human: the split-half human ceiling (blur, metric, value); summary: truth.json as a dict.
    """

    fixations: pd.DataFrame
    counts: np.ndarray
    density: np.ndarray
    cone: np.ndarray | None
    human: pd.DataFrame
    summary: dict

    def __init__(self, inner: _meshgaze.Truth):
        self._inner = inner
        self.fixations = _read_csv(io.StringIO(inner.fixations_csv), keep_default_na=False,
                                     na_values=[""])
        self.counts = inner.counts
        self.density = inner.density
        self.cone = inner.cone
        self.human = _pandas().DataFrame(inner.human, columns=["blur", "metric", "value"])
        self.summary = json.loads(inner.summary_json)

    def __repr__(self) -> str:
        s = self.summary
        return (f"Truth({s['fixations_on_mesh']} fixations on the mesh from "
                f"{len(s['subjects'])} subjects)")


def build_truth(stimulus: PathLike, projected: Any, out_dir: PathLike | None = None,
                **options: Any) -> Truth:
    """Build a mesh's ground truth from projected fixations of several subjects, as
    `meshgaze truth`.

    projected: projected.csv paths (or folders holding one), or DataFrames that
    project(..., out_dir=...) returned. With out_dir, writes truth.csv, density.csv,
    truth.ply, human.csv and truth.json there.
    Options: blur (σ_b of the density, default 0.02), blur_max, blur_step (the human-ceiling
    sweep), kernel (euclidean, heat), mesh (if it moved since rendering), progress.
    """
    if _is_path(projected) or isinstance(projected, _pandas().DataFrame):
        projected = [projected]
    files = []
    for p in projected:
        if isinstance(p, _pandas().DataFrame):
            if "path" not in p.attrs:
                raise ValueError("a projection DataFrame is only usable here when it was "
                                 "written: call project(..., out_dir=DIR)")
            files.append(p.attrs["path"])
        else:
            files.append(os.fsdecode(p))
    inner = _meshgaze.build_truth(os.fsdecode(stimulus), files, out_dir=_path_or_none(out_dir),
                                  **options)
    return Truth(inner)


class Study:
    """A whole study (study.toml; `meshgaze study init MESH_DIR` writes one).

    run(jobs=1, shard=None) renders, ingests, projects, builds truth, computes and scores
    every mesh whose inputs changed, as `meshgaze study run` (resumable: finished steps are
    up to date), and returns study.json's account as a dict; merge() joins sharded runs;
    scores() reads scores.csv as a DataFrame.
    """

    def __init__(self, path: PathLike):
        self._inner = _meshgaze.Study(os.fsdecode(path))

    @property
    def output(self) -> str:
        """The output folder."""
        return os.fsdecode(self._inner.output)

    @property
    def meshes(self) -> list[str]:
        """The meshes' names, sorted."""
        return self._inner.meshes

    @property
    def recordings(self) -> list[str]:
        """The recordings found when the study was read."""
        return [os.fsdecode(p) for p in self._inner.recordings]

    @property
    def methods(self) -> list[str]:
        """The saliency methods scored."""
        return self._inner.methods

    def run(self, jobs: int = 1, shard: tuple[int, int] | None = None,
            progress: bool = False) -> dict:
        """Run (or resume) the study; shard=(i, n) runs the i-th of n shares of the meshes.
        study.toml is read again first, so recordings made since are found."""
        return json.loads(self._inner.run(jobs=jobs, shard=shard, progress=progress))

    def merge(self) -> dict:
        """Join every shard's scores into scores.csv and write the report."""
        merged, report = self._inner.merge()
        return {"meshes": merged, "report": os.fsdecode(report)}

    def scores(self) -> pd.DataFrame:
        """scores.csv: mesh, method, metric, blur, value."""
        return _read_csv(os.path.join(self.output, "scores.csv"))

    def __repr__(self) -> str:
        return repr(self._inner)


def view(mesh: MeshLike, out: PathLike, maps: Mapping[str, np.ndarray] | None = None,
         truth: Truth | np.ndarray | None = None, fixations: Any = None,
         stimulus: PathLike | None = None, max_triangles: int = 500_000,
         title: str | None = None) -> str:
    """Write the interactive 3D viewer of `meshgaze view` to `out` (one offline HTML file) and
    return its path: the mesh coloured by each of `maps` (name -> per-vertex array) or the
    truth density, with fixations as dots by subject, and with `stimulus` (the folder
    render_stimulus wrote for this mesh) buttons showing the video's own hold views.

    truth: a Truth (its density, and its fixations unless `fixations` is given) or a density
    array. fixations: DataFrames from project(), projected.csv paths, or a Truth.
    """
    mesh = _as_mesh(mesh)
    named = [(str(k), np.ascontiguousarray(v, dtype=np.float64)) for k, v in (maps or {}).items()]
    density, blur, texts = None, float("nan"), []
    if isinstance(truth, Truth):
        density = np.ascontiguousarray(truth.density, dtype=np.float64)
        blur = float(truth.summary.get("blur", float("nan")))
        if fixations is None:
            fixations = truth
    elif truth is not None:
        density = np.ascontiguousarray(truth, dtype=np.float64)
    if fixations is not None:
        if _is_path(fixations) or isinstance(fixations, Truth) or hasattr(fixations, "attrs"):
            fixations = [fixations]
        for f in fixations:
            if isinstance(f, Truth):
                texts.append(f._inner.fixations_csv)
            elif hasattr(f, "attrs") and "csv" in getattr(f, "attrs", {}):
                texts.append(f.attrs["csv"])
            elif _is_path(f):
                p = os.fsdecode(f)
                if os.path.isdir(p):
                    p = os.path.join(p, "projected.csv")
                with open(p, encoding="utf-8-sig") as src:
                    texts.append(src.read())
            else:
                raise TypeError("fixations: expected DataFrames from project(), projected.csv "
                                f"paths or a Truth, not {type(f).__name__}")
    page = _meshgaze.view_html(mesh, named, density=density, blur=blur, fixations_csv=texts,
                               stimulus=_path_or_none(stimulus), max_triangles=max_triangles,
                               title=title)
    path = os.fsdecode(out)
    # newline="": the page's bytes as the CLI writes them, on every platform.
    with open(path, "w", encoding="utf-8", newline="") as dst:
        dst.write(page)
    return path
