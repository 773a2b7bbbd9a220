"""Shared fixtures: the repository, the `meshgaze` binary the Python results are compared
with, and ../shared/data (real exports).

Data that is missing is a skip with its reason outside CI (pytest lists it as skipped, never
as passed) and a failure under CI, where ../shared is always present."""
import os
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def run_cli(*args, cwd=None):
    """Runs the meshgaze binary; a failure shows its stderr."""
    r = subprocess.run([str(cli_path()), *map(str, args)], cwd=cwd, capture_output=True,
                       text=True)
    if r.returncode != 0:
        raise AssertionError(f"meshgaze {' '.join(map(str, args))} failed:\n{r.stderr}")
    return r


def cli_path():
    explicit = os.environ.get("MESHGAZE_BIN")
    if explicit:
        return Path(explicit)
    path = REPO / "target" / "release" / "meshgaze"
    if not path.exists():
        subprocess.run(["cargo", "build", "--release", "--bin", "meshgaze"], cwd=REPO,
                       check=True)
    return path


@pytest.fixture(scope="session")
def cli():
    return run_cli


@pytest.fixture(scope="session")
def repo():
    return REPO


@pytest.fixture(scope="session")
def shared_data():
    path = REPO.parent / "shared" / "data"
    if not path.is_dir():
        message = f"needs ../shared/data (real exports), not found at {path}"
        if os.environ.get("CI"):
            pytest.fail(message + "; CI always has it")
        pytest.skip(message)
    return path


def medium_protocol_text():
    """The paper's protocol made small enough for a test: 320x200, 3 turntable views held 2 s
    with 0.5 s moves (7.5 s of video), so simulated subjects still make a dozen fixations."""
    text = (REPO / "protocols" / "hu2020.toml").read_text()
    for old, new in [("width_px = 1680", "width_px = 320"), ("height_px = 1050", "height_px = 200"),
                     ('generator = "icosahedron"', 'generator = "turntable"'),
                     ("count = 12", "count = 3"), ("hold_s = 3.0", "hold_s = 2.0"),
                     ("move_s = 1.0", "move_s = 0.5")]:
        assert old in text, f"protocols/hu2020.toml no longer has `{old}`"
        text = text.replace(old, new)
    return text


@pytest.fixture(scope="session")
def bunny_dir(tmp_path_factory):
    """A folder with the bundled 1,889-vertex bunny as bunny.ply and the medium protocol."""
    d = tmp_path_factory.mktemp("bunny")
    shutil.copy(REPO / "stimuli" / "meshes" / "bun_zipper_res3.ply", d / "bunny.ply")
    (d / "medium.toml").write_text(medium_protocol_text())
    return d
