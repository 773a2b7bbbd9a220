"""Types of the compiled module (python/src/*.rs). Use the `meshgaze` package's functions;
these are the calls they wrap."""
from os import PathLike
from typing import Any, Sequence

import numpy as np

_Path = str | PathLike[str]

class MeshgazeError(Exception):
    """An input meshgaze cannot use; the message is the command line's (file, line, column)."""

class Mesh:
    """A triangle mesh: vertex positions and triangles, in file order."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        """vertices an (n, 3) float64 array, faces an (m, 3) int64 array of vertex indices."""
    @property
    def vertices(self) -> np.ndarray:
        """(n, 3) float64 vertex positions."""
    @property
    def faces(self) -> np.ndarray:
        """(m, 3) int64 triangles (vertex indices)."""
    @property
    def path(self) -> str | None:
        """The file the mesh was read from, or None for a mesh from arrays."""
    @property
    def load_report_json(self) -> str | None:
        """What the file reader found and left out (JSON text), or None for arrays."""

class Truth:
    @property
    def fixations_csv(self) -> str: ...
    @property
    def counts(self) -> np.ndarray: ...
    @property
    def density(self) -> np.ndarray: ...
    @property
    def cone(self) -> np.ndarray | None: ...
    @property
    def human(self) -> list[tuple[float, str, float]]: ...
    @property
    def summary_json(self) -> str: ...

class Study:
    def __init__(self, path: _Path) -> None: ...
    @property
    def output(self) -> str: ...
    @property
    def meshes(self) -> list[str]: ...
    @property
    def recordings(self) -> list[str]: ...
    @property
    def methods(self) -> list[str]: ...
    def run(self, jobs: int = 1, shard: tuple[int, int] | None = None,
            progress: bool = False) -> str: ...
    def merge(self) -> tuple[int, str]: ...

def read_mesh(path: _Path) -> Mesh:
    """OBJ, PLY (ASCII or binary) or OFF, optionally gzipped."""

def saliency(mesh: Mesh, method: str = "sms", seed: int = 1, settings: Sequence[str] = ...,
             protocol: str | None = None, model: str | None = None, progress: bool = False,
             **params: Any) -> np.ndarray: ...

def read_gaze(paths: Sequence[str], protocol: str | None = None, format: str | None = None,
              detector: str | None = None, eye: str = "best", validity: str = "auto",
              subject: str | None = None, screen: tuple[float, float] | None = None,
              stimulus_pattern: str | None = None, stimulus_end_pattern: str | None = None,
              max_dispersion_px: float | None = None, min_duration_ms: float | None = None,
              max_velocity_deg_s: float | None = None, samples: bool = False
              ) -> dict[str, Any]: ...

def score(mesh: Mesh, maps: Sequence[tuple[str, np.ndarray]],
          truth_values: np.ndarray | None = None, truth_path: str | None = None,
          truth: Truth | None = None, blur: Sequence[float] | None = None, seed: int = 1,
          kernel: str = "euclidean", weighting: str = "vertex", top_fraction: float = 0.05,
          borji_splits: int = 100, protocol: str | None = None, truth_layout: str = "auto",
          progress: bool = False
          ) -> tuple[list[tuple[str, str, float, float]], str]: ...

def render_stimulus(mesh: Mesh, out_dir: str, protocol: str | None = None,
                    frames: str = "none", id_buffer: bool = False, verify: bool = False,
                    progress: bool = False) -> str: ...

def project(stimulus: str, fixations: Sequence[str], out_dir: str | None = None,
            stimulus_name: str | None = None, onset_us: int | None = None,
            screen: tuple[float, float] | None = None, during_move: str | None = None,
            snap: bool = False, snap_deg: float | None = None, cone_deg: float | None = None,
            mesh: str | None = None, targets: str | None = None, self_check: bool = True,
            progress: bool = False) -> tuple[str, str]: ...

def build_truth(stimulus: str, projected: Sequence[str], out_dir: str | None = None,
                blur: float = 0.02, blur_max: float = 0.2, blur_step: float = 0.01,
                kernel: str = "euclidean", mesh: str | None = None, progress: bool = False
                ) -> Truth: ...

def view_html(mesh: Mesh, maps: Sequence[tuple[str, np.ndarray]],
              density: np.ndarray | None = None, blur: float = ...,
              fixations_csv: Sequence[str] = ..., stimulus: str | None = None,
              max_triangles: int = 500000, title: str | None = None) -> str: ...

def version() -> str: ...
