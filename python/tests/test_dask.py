"""The Dask recipe (examples/python/posekit_dask.py) on a LocalCluster of 2 worker processes against
`posekit batch measure` on the same folder: the same table."""
import importlib.util
import io
import os
import pathlib
import shutil
import subprocess

import numpy as np
import pytest

import posekit

distributed = pytest.importorskip("dask.distributed")
pd = pytest.importorskip("pandas")

RECIPE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "python" / "posekit_dask.py"


def _recipe():
    spec = importlib.util.spec_from_file_location("posekit_dask", RECIPE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_measure_on_two_workers_gives_batch_measures_table(tmp_path, dataset):
    cli = os.environ.get("POSEKIT_CLI") or shutil.which("posekit")
    folder = tmp_path / "bodies"
    folder.mkdir()
    # Real-life variety: meshes in metres, scans in millimetres (PCD), a Z-up copy in millimetres,
    # a mesh file without faces, and a broken file.
    for person in ("f01", "m01"):
        shutil.copy(dataset / "subjects" / person / "rest.ply", folder / f"{person}.ply")
        shutil.copy(dataset / "scans" / person / "rest.pcd", folder / f"{person}_scan.pcd")
        shutil.copy(dataset / "subjects" / person / "posed" / "squat_half.ply", folder / f"{person}_squat.ply")
    V, F = posekit.read_mesh(folder / "f01.ply")
    to_file = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], dtype=float)
    posekit.write_mesh(folder / "f01_z_up_mm.ply", 1000.0 * V @ to_file.T, F)
    posekit.write_point_cloud(folder / "m01_points.ply", posekit.read_mesh(folder / "m01.ply")[0])
    (folder / "broken.obj").write_text("v 0 0 0\nf 1 2 3\n")
    subprocess.run([cli, "batch", "measure", "--inputs", str(folder), "--out", str(tmp_path / "batch")], capture_output=True)
    by_batch = pd.read_csv(tmp_path / "batch" / "summary.csv", dtype=str, keep_default_na=False)
    recipe = _recipe()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        table = recipe.measure_table(client, recipe.list_inputs(folder))
        workers = {w for w in client.run(os.getpid).values()}
    assert len(workers) == 2
    by_dask = pd.read_csv(io.StringIO(table.to_csv(index=False)), dtype=str, keep_default_na=False)
    assert list(by_dask.columns) == list(by_batch.columns)
    assert (by_batch["status"] == "failed").sum() >= 1  # the broken file at least
    pd.testing.assert_frame_equal(by_dask, by_batch)


def test_the_recipes_command_line_poses_with_the_model_loaded_once_per_worker(tmp_path, dataset, model):
    recipe = _recipe()
    model.save(tmp_path / "m.pkm")
    subjects = [str(dataset / "subjects" / p / "rest.ply") for p in ("f01", "m01")]
    pose = str(dataset / "subjects" / "f01" / "posed" / "squat_half.json")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        table = recipe.pose_table(client, subjects, str(tmp_path / "m.pkm"), pose, str(tmp_path / "posed"))
        loads = client.run(lambda dask_worker: len(getattr(dask_worker, "posekit_models", {})))
    assert (table["status"] == "ok").all(), table
    for subject, out in zip(subjects, table["output"]):
        expected = posekit.Subject(model, *posekit.read_mesh(subject)).pose(pose)
        assert np.abs(posekit.read_mesh(out)[0] - expected).max() < 2e-6  # float32 file
    assert sum(loads.values()) >= 1 and all(n <= 1 for n in loads.values())  # the one model, once per worker that ran a task
