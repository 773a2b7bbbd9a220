"""meshgaze from Python: mesh saliency, gaze recordings and scoring, as numpy arrays and
pandas DataFrames. Every call is a thin wrapper over the meshgaze Rust library, so the
values are the ones the `meshgaze` command line writes."""
import io

import numpy as np
import pandas as pd

from . import _meshgaze
from ._meshgaze import Mesh, MeshgazeError, read_mesh

__all__ = ["Mesh", "MeshgazeError", "read_mesh", "saliency", "read_gaze", "Recording", "score"]
__version__ = _meshgaze.version()


def _as_mesh(mesh):
    if isinstance(mesh, Mesh):
        return mesh
    # trimesh, open3d-converted or any object with vertices and faces
    return Mesh(np.ascontiguousarray(mesh.vertices, dtype=np.float64),
                np.ascontiguousarray(mesh.faces, dtype=np.int64))


def saliency(mesh, method="sms", seed=1, **params):
    """Per-vertex saliency in [0, 1] of `method` (sms, mc, ms, si, sri, mr, gr, up, centre,
    gaze), the values `meshgaze saliency --method METHOD --seed SEED` writes. SMS keywords:
    samples, mu, sigma, scales, shells, bands, grid, ...; settings=["sri.most_similar=32"]
    for the rarity methods; protocol=, model= (gaze); progress=True prints steps."""
    return _meshgaze.saliency(_as_mesh(mesh), method, seed, **params)


class Recording:
    """Fixations, messages, quality (and samples when asked) of one or more recordings,
    as DataFrames with the columns of `meshgaze ingest`'s CSV files."""

    def __init__(self, tables):
        self.fixations = pd.read_csv(io.StringIO(tables["fixations"]))
        self.messages = pd.read_csv(io.StringIO(tables["messages"]), keep_default_na=False)
        self.quality = pd.read_csv(io.StringIO(tables["quality"]))
        s = tables["samples"]
        self.samples = pd.read_csv(io.StringIO(s)) if s is not None else None
        self.files = [
            {"path": p, "subject": sub, "fixations": n, "notes": notes}
            for p, sub, n, notes in tables["files"]
        ]

    def __repr__(self):
        return f"Recording({len(self.files)} files, {len(self.fixations)} fixations)"


def read_gaze(paths, **ingest_options):
    """Read eye-tracker recordings (SMI, EyeLink, Tobii, Pupil Labs, Gazepoint; detected
    from content) as `meshgaze ingest` does. Options: protocol, detector, eye, validity,
    subject, screen=(w, h), stimulus_pattern, stimulus_end_pattern, max_dispersion_px,
    min_duration_ms, max_velocity_deg_s, samples=True for the sample table."""
    if isinstance(paths, (str, bytes)) or hasattr(paths, "__fspath__"):
        paths = [paths]
    return Recording(_meshgaze.read_gaze([str(p) for p in paths], **ingest_options))


def score(mesh, saliency, truth, blur=None, metrics=None, **options):
    """Score maps against human truth as `meshgaze score` does; returns a DataFrame with
    columns method, metric, blur, value (chance and, for fixation sets with subjects, the
    human ceiling included). `saliency` is an array or a dict name -> array; `truth` an
    array (one value per vertex) or a truth file. Options: seed, kernel, weighting,
    top_fraction, borji_splits, progress."""
    mesh = _as_mesh(mesh)
    if isinstance(saliency, dict):
        maps = [(str(k), np.ascontiguousarray(v, dtype=np.float64)) for k, v in saliency.items()]
    else:
        maps = [("map", np.ascontiguousarray(saliency, dtype=np.float64))]
    if isinstance(truth, (str, bytes)) or hasattr(truth, "__fspath__"):
        rows, _ = _meshgaze.score(mesh, maps, truth_path=str(truth), blur=blur, **options)
    else:
        values = np.ascontiguousarray(truth, dtype=np.float64)
        rows, _ = _meshgaze.score(mesh, maps, truth_values=values, blur=blur, **options)
    table = pd.DataFrame(rows, columns=["method", "metric", "blur", "value"])
    if metrics is not None:
        table = table[table["metric"].isin(list(metrics))].reset_index(drop=True)
    return table
