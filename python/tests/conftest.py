"""Fixtures the module's tests share: the small posekit dataset (made once per session by the CLI), a
pose model trained on it, and a small body model."""
import os
import shutil
import subprocess

import pytest

import posekit


@pytest.fixture(scope="session")
def dataset(tmp_path_factory):
    cli = os.environ.get("POSEKIT_CLI") or shutil.which("posekit")
    assert cli, "set POSEKIT_CLI to the posekit executable"
    out = tmp_path_factory.mktemp("data") / "ds"
    subprocess.run([cli, "dataset", "make", "--small", "--out", str(out)], check=True, capture_output=True)
    return out


@pytest.fixture(scope="session")
def model(dataset):
    return posekit.train(str(dataset), calibration_bodies=8)


@pytest.fixture(scope="session")
def f01(dataset):
    return posekit.read_mesh(str(dataset / "subjects" / "f01" / "rest.ply"))


@pytest.fixture(scope="session")
def body_model_file(tmp_path_factory):
    """A small body model: 40 ANSUR II subjects, the built-in pose library (about a second)."""
    cli = os.environ.get("POSEKIT_CLI") or shutil.which("posekit")
    out = tmp_path_factory.mktemp("bm") / "a40.pks"
    subprocess.run([cli, "shape-space", "--ansur", "--subjects", "40", "--motions", "none", "--out", str(out)], check=True,
                   capture_output=True)
    return out
