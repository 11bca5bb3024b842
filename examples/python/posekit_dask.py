"""posekit on a Dask cluster: measure, compare, pose, customize and fit mapped over many inputs.

    python3 examples/python/posekit_dask.py measure DIR|LIST [--scheduler ADDRESS | --workers N] [--out table.csv]
    python3 examples/python/posekit_dask.py compare PAIRS.csv ...   (lines "model,scan")
    python3 examples/python/posekit_dask.py pose DIR|LIST --model model.pkm --pose pose.json --out-dir DIR ...
    python3 examples/python/posekit_dask.py fit TARGETS --model model.pkm --subject rest.ply ...

Each task reads its own input on a worker and returns one row; models (a pose model, a subject
set up for posing, a body model, a photo customization model) are loaded once per worker process
(kept on the worker by `_cached`) and reused by every task that worker runs. The rows come back as a pandas
DataFrame. `measure_table` gives `posekit batch measure`'s summary.csv row for row (the same
columns, numbers written the same way, the same failures with the same messages): the library reads
and measures the same way for both (Debian: python3-distributed, python3-pandas).

On a cluster, start a scheduler and workers (`dask scheduler`, `dask worker ADDRESS`) on machines
that see the inputs, and pass --scheduler ADDRESS; without it a LocalCluster of --workers processes
runs here.
"""
import argparse
import os
import pathlib
import sys
import warnings

import pandas as pd

import posekit

CLOUD_EXTENSIONS = {".pcd", ".xyz", ".pts", ".txt"}
MESH_EXTENSIONS = {".ply", ".obj", ".off", ".stl"}


def list_inputs(where):
    """The files of a folder (recursively, sorted, as `posekit batch` lists them) or of a list file."""
    where = pathlib.Path(where)
    if where.is_dir():
        return sorted(str(p) for p in where.rglob("*") if p.is_file() and p.suffix.lower() in MESH_EXTENSIONS | {".pcd", ".xyz"})
    return [line.strip() for line in where.read_text().splitlines() if line.strip() and not line.startswith("#")]


def _load(kind, *args):
    if kind == "pose_model":
        return posekit.PoseModel.load(args[0])
    if kind == "body_model":
        return posekit.BodyModel(args[0])
    if kind == "subject":
        model_path, subject_path = args
        return posekit.Subject(_cached("pose_model", model_path), *posekit.read_mesh(subject_path))
    raise ValueError(kind)


_HERE = {}  # the models of tasks run in this process outside a worker


def _cached(kind, *args):
    """A model, loaded once per worker process and kept on the worker for the tasks it runs next (the
    worker's own state: the task functions themselves travel by value and keep nothing)."""
    try:
        from dask.distributed import get_worker

        store = get_worker().__dict__.setdefault("posekit_models", {})
    except (ImportError, ValueError):
        store = _HERE
    key = (kind,) + args
    if key not in store:
        store[key] = _load(kind, *args)
    return store[key]


def read_body(path):
    """A mesh (V, F), or a point cloud (P, None) for a cloud format or a mesh file without faces, as
    posekit's commands read bodies; the readers' caveats are returned."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if pathlib.Path(path).suffix.lower() not in CLOUD_EXTENSIONS:
            try:
                V, F = posekit.read_mesh(path)
                return V, F, [str(w.message) for w in caught]
            except posekit.IoError as e:
                if "no faces" not in str(e):
                    raise
                caught.clear()
        P = posekit.read_point_cloud(path)
        return P, None, [str(w.message) for w in caught]


def _number(value):
    return "" if value is None else f"{value:.6f}"


def _row(index, path, error=None):
    return {"index": index, "input": path, "status": "failed" if error else "ok", "error": error or ""}


def measure_one(index, path):
    """One row of batch measure's summary: unit, axes, stature and girths (m), warnings counted."""
    row = _row(index, path)
    try:
        V, F, read_warnings = read_body(path)
        m = posekit.measure(V, F)
    except posekit.Error as e:
        row.update(_row(index, path, str(e)))
        return row
    row.update({"kind": "mesh" if F is not None else "point cloud", "unit": m["frame"]["unit"], "up": m["frame"]["up"],
                "forward": m["frame"]["forward"], "stature_m": _number(m["stature"]),
                "stature_measured": "1" if m["stature_measured"] else "0"})
    for name in posekit.girth_names:
        g = m["girths"][name]
        row[name + "_m"] = _number(g["value"]) if g["measured"] else ""
    row["warnings"] = str(len(read_warnings) + len(m["warnings"]))
    return row


def compare_one(index, model_path, scan_path):
    row = _row(index, model_path)
    row["scan"] = scan_path
    try:
        V, F, _ = read_body(model_path)
        if F is None:
            raise posekit.InvalidInput(model_path + ": the model must be a mesh (triangles); this file has only points")
        P, _, _ = read_body(scan_path)
        c = posekit.compare(V, F, P)
    except posekit.Error as e:
        row.update(_row(index, model_path, str(e)))
        return row
    for key in ("mean_mm", "rms_mm", "p95_mm", "max_mm"):
        row["scan_to_model_" + key] = c["scan_stats"][key]
        row["model_to_scan_" + key] = c["model_stats"][key]
    row["coverage"] = c["coverage"]
    return row


def pose_one(index, subject_path, model_path, pose_path, out_dir, method):
    row = _row(index, subject_path)
    try:
        subject = posekit.Subject(_cached("pose_model", model_path), *posekit.read_mesh(subject_path))
        V = subject.pose(pose_path, method=method)
        out = pathlib.Path(out_dir) / f"{index:04d}_{pathlib.Path(subject_path).stem}_posed.ply"  # stems may repeat
        posekit.write_mesh(out, V, subject.faces)
    except posekit.Error as e:
        row.update(_row(index, subject_path, str(e)))
        return row
    row["output"] = str(out)
    row["skeleton_problems"] = len(subject.skeleton_problems)
    return row


def fit_one(index, target_path, model_path, subject_path):
    row = _row(index, target_path)
    try:
        subject = _cached("subject", model_path, subject_path)  # set up once per worker
        T, F, _ = read_body(target_path)
        fit = subject.fit(T, F)
    except posekit.Error as e:
        row.update(_row(index, target_path, str(e)))
        return row
    row.update({"target_to_body_mean_mm": fit["target_to_body_mm"]["mean"], "target_to_body_p95_mm": fit["target_to_body_mm"]["p95"],
                "coverage_1cm": fit["coverage_1cm"], "iterations": fit["iterations"], "warnings": len(fit["warnings"])})
    for name in posekit.joint_names:
        row[name + "_deg"] = float(sum(x * x for x in fit["pose"]["joints"][name]) ** 0.5 * 180 / 3.141592653589793)
    return row


def customize_one(index, front, side, camera, method, model_path, height):
    row = _row(index, front)
    try:
        model = _cached("body_model", model_path) if method == "model" else model_path
        body = posekit.customize(front, side, camera=camera, height=height, method=method, model=model)
        m = posekit.measure(body["V"], body["F"])
    except posekit.Error as e:
        row.update(_row(index, front, str(e)))
        return row
    row.update({"photo_agreement": body["photo_agreement"], "stature_m": _number(m["stature"])})
    for name in ("bust", "waist", "hip"):
        g = m["girths"][name]
        row[name + "_m"] = _number(g["value"]) if g["measured"] else ""
    row["warnings"] = len(body["warnings"])
    return row


def _table(client, function, argument_lists):
    """Maps `function` over the argument tuples on the cluster; one DataFrame, in input order."""
    futures = [client.submit(function, i, *args, pure=False) for i, args in enumerate(argument_lists)]
    rows = client.gather(futures)
    return pd.DataFrame(rows).sort_values("index").reset_index(drop=True)


def measure_table(client, inputs):
    return _table(client, measure_one, [(p,) for p in inputs])


def compare_table(client, pairs):
    return _table(client, compare_one, list(pairs))


def pose_table(client, subjects, model_path, pose_path, out_dir, method="learned"):
    os.makedirs(out_dir, exist_ok=True)
    return _table(client, pose_one, [(s, model_path, pose_path, out_dir, method) for s in subjects])


def fit_table(client, targets, model_path, subject_path):
    return _table(client, fit_one, [(t, model_path, subject_path) for t in targets])


def customize_table(client, photo_sets, method, model_path, height=0.0):
    """photo_sets: (front, side, camera file) per person."""
    return _table(client, customize_one, [(f, s, c, method, model_path, height) for f, s, c in photo_sets])


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("task", choices=["measure", "compare", "pose", "fit"])
    parser.add_argument("inputs", help="folder or list file (compare: lines 'model,scan')")
    parser.add_argument("--scheduler", help="a running Dask scheduler's address (default: a LocalCluster here)")
    parser.add_argument("--workers", type=int, default=2, help="LocalCluster worker processes")
    parser.add_argument("--model", help="pose model (.pkm) for pose and fit")
    parser.add_argument("--pose", help="pose JSON for pose")
    parser.add_argument("--subject", help="the subject's rest mesh for fit")
    parser.add_argument("--out-dir", default="posed", help="pose: where the posed meshes go")
    parser.add_argument("--out", help="write the table as CSV here (default: print it)")
    args = parser.parse_args(argv)
    from dask.distributed import Client, LocalCluster

    cluster = None if args.scheduler else LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True)
    with Client(args.scheduler or cluster) as client:
        if args.task == "measure":
            table = measure_table(client, list_inputs(args.inputs))
        elif args.task == "compare":
            pairs = [tuple(line.split(",", 1)) for line in pathlib.Path(args.inputs).read_text().splitlines() if line.strip()]
            table = compare_table(client, pairs)
        elif args.task == "pose":
            table = pose_table(client, list_inputs(args.inputs), args.model, args.pose, args.out_dir)
        else:
            table = fit_table(client, list_inputs(args.inputs), args.model, args.subject)
    if cluster:
        cluster.close()
    if args.out:
        table.to_csv(args.out, index=False)
    else:
        print(table.to_string())
    return 0 if (table["status"] == "ok").all() else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
