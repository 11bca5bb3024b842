"""The Python module on real data: the small posekit dataset (made once per session by the CLI),
every bound function, and its error path."""
import json
import pickle
import os
import pathlib
import shutil
import subprocess
import threading

import numpy as np
import pytest

import posekit


def test_version_and_names():
    assert posekit.__version__.count(".") == 2
    assert len(posekit.joint_names) == 15 and posekit.joint_names[0] == "lower_back"
    assert len(posekit.part_names) == 16


def test_meshes_and_clouds_round_trip(tmp_path, f01):
    V, F = f01
    assert V.shape[1] == 3 and F.shape[1] == 3 and F.dtype == np.int32
    posekit.write_mesh(str(tmp_path / "b.obj"), V, F)
    V2, F2 = posekit.read_mesh(str(tmp_path / "b.obj"))
    assert np.array_equal(F, F2) and np.abs(V - V2).max() < 1e-6
    posekit.write_point_cloud(str(tmp_path / "p.ply"), V)
    assert np.array_equal(posekit.read_point_cloud(str(tmp_path / "p.ply")), V)
    with pytest.raises(posekit.IoError, match="cannot open"):
        posekit.read_mesh(str(tmp_path / "missing.ply"))
    with pytest.raises(OSError):  # IoError is an OSError
        posekit.read_point_cloud(str(tmp_path / "missing.pcd"))
    with pytest.raises(posekit.InvalidInput, match="outside the"):
        posekit.write_mesh(str(tmp_path / "bad.ply"), V[:10], F)
    assert not (tmp_path / "bad.ply").exists()
    # pathlib paths, and the fields a PLY holds besides the geometry, kept both ways.
    rng = np.random.default_rng(1)
    normals = rng.normal(size=V.shape)
    colors = rng.integers(0, 256, size=V.shape).astype(np.uint8)
    error = rng.random(V.shape[0])
    posekit.write_mesh(tmp_path / "f.ply", V, F, normals=normals, colors=colors, scalars={"error_mm": error})
    V3, F3, extra = posekit.read_mesh(tmp_path / "f.ply", fields=True)
    assert np.array_equal(F3, F) and np.abs(V3 - V).max() < 1e-6
    assert np.abs(extra["normals"] - normals).max() < 1e-5 and np.array_equal(extra["colors"], colors)
    assert np.abs(extra["vertex_scalars"]["error_mm"] - error).max() < 1e-5
    assert extra["uv"].shape == (0, 2) and extra["face_scalars"] == {}
    posekit.write_point_cloud(tmp_path / "q.ply", V, normals=normals, scalars={"intensity": error})
    P, cloud_extra = posekit.read_point_cloud(tmp_path / "q.ply", fields=True)
    assert np.abs(P - V).max() < 1e-6 and np.abs(cloud_extra["scalars"]["intensity"] - error).max() < 1e-5
    assert np.abs(cloud_extra["normals"] - normals).max() < 1e-5
    with pytest.raises(posekit.InvalidInput, match="'error_mm' has 3 values"):
        posekit.write_mesh(tmp_path / "g.ply", V, F, scalars={"error_mm": np.zeros(3)})


def test_validate_counts_a_meshs_defects_as_info_does(f01):
    V, F = f01
    report = posekit.validate(V, F)
    assert report["usable"] and report["watertight"] and report["components"] == 1, report
    assert report["vertices"] == V.shape[0] and report["surface_area"] > 1.0  # m^2
    broken = F.copy()
    broken[0, 0] = V.shape[0] + 5  # out of range: counted, not raised
    bad = posekit.validate(V, np.vstack([broken, F[:1]]))
    assert not bad["usable"] and bad["out_of_range_indices"] == 1 and bad["duplicate_faces"] == 0


def test_measure_a_mesh_and_its_scan(dataset, f01):
    V, F = f01
    truth = json.loads((dataset / "subjects" / "f01" / "measurements.json").read_text())
    m = posekit.measure(V, F)
    assert m["stature"] == pytest.approx(truth["stature"], abs=0.01)
    for name in ("bust", "waist", "hip"):
        g = m["girths"][name]
        assert g["measured"], g["note"]
        assert g["value"] == pytest.approx(truth["girths"][name], abs=0.012), name
    scan = posekit.read_point_cloud(str(dataset / "scans" / "f01" / "rest.pcd")) / 1000.0  # mm
    s = posekit.measure(scan)
    assert s["girths"]["hip"]["value"] == pytest.approx(m["girths"]["hip"]["value"], abs=0.012)
    assert m["frame"]["unit"] == "m" and m["frame"]["up"] == "+Y" and m["frame"]["forward"] == "+Z"
    # Any unit and axes, as the CLI reads them: the same body in millimetres, Z up, facing -Y.
    to_file = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], dtype=float)  # posekit -> file axes
    z_up = posekit.measure(1000.0 * V @ to_file.T, F)
    assert z_up["frame"]["unit"] == "mm" and z_up["frame"]["unit_detected"]
    assert z_up["frame"]["up"] == "+Z" and z_up["frame"]["forward"] == "-Y", z_up["frame"]
    for name in ("bust", "waist", "hip"):
        assert z_up["girths"][name]["value"] == pytest.approx(m["girths"][name]["value"], abs=1e-6), name
        # The tape's path: a closed polyline as long as the girth, in the caller's unit and axes.
        tape = z_up["girths"][name]["tape"]
        assert tape.shape[1] == 3 and tape.shape[0] >= 8
        length = np.linalg.norm(tape - np.roll(tape, 1, axis=0), axis=1).sum()
        assert length == pytest.approx(1000.0 * m["girths"][name]["value"], rel=1e-9), name
        # the girth's point comes back in the caller's unit and axes
        assert np.abs(np.array(z_up["girths"][name]["point"]) - 1000.0 * to_file @ np.array(m["girths"][name]["point"])).max() < 1e-3
    given = posekit.measure(1000.0 * V @ to_file.T, F, unit="mm", up="+Z", forward="-Y")
    assert given["girths"]["hip"]["value"] == pytest.approx(m["girths"]["hip"]["value"], abs=1e-6)
    assert not given["frame"]["unit_detected"]
    with pytest.raises(posekit.InvalidInput, match="tall"):
        posekit.measure(V * 1000.0, F, unit="m")  # millimetres said to be metres
    with pytest.raises(posekit.InvalidInput, match="cannot tell its unit") as error:
        posekit.measure(V * 20.0, F)  # 35 m tall in metres, 3.5 in dm: no unit explains it
    assert "--unit" not in str(error.value)
    with pytest.raises(ValueError):  # InvalidInput is a ValueError
        posekit.measure(np.random.default_rng(0).random((100, 3)))


def test_train_save_load(tmp_path, dataset, model):
    assert model.training_poses > 10 and model.calibration_bodies >= 8
    model.save(str(tmp_path / "m.pkm"))
    loaded = posekit.PoseModel.load(str(tmp_path / "m.pkm"))
    assert loaded.training_poses == model.training_poses
    assert np.array_equal(loaded.template[1], model.template[1])
    copy = pickle.loads(pickle.dumps(model))  # the .pkm bytes, checksum and all
    assert copy.training_poses == model.training_poses and np.array_equal(copy.template[0], model.template[0])
    broken = posekit.PoseModel.__new__(posekit.PoseModel)
    with pytest.raises(posekit.IoError, match="a pickled PoseModel"):
        broken.__setstate__(b"not a model")
    with pytest.raises(posekit.Error):
        posekit.train(str(tmp_path / "no_dataset"), calibration_bodies=0)
    (tmp_path / "junk.pkm").write_bytes(b"not a model")
    with pytest.raises(posekit.Error, match="POSEKPKM"):
        posekit.PoseModel.load(str(tmp_path / "junk.pkm"))


def test_segment(f01, model):
    V, F = f01
    s = posekit.segment(V, F, model)
    parts = np.bincount(s["triangle_part"], minlength=16)
    assert parts.shape == (16,) and (parts > 20).all()
    joints = s["joints"]
    assert joints.shape == (15, 3)
    left, right = posekit.joint_names.index("left_hip"), posekit.joint_names.index("right_hip")
    assert joints[left, 0] > joints[right, 0]  # left is +X
    assert s["problems"] == []
    assert posekit.segment(V, F)["joints"].shape == (15, 3)  # without a model
    # Lying on its side (a turn about Z): found upright as the CLI finds it, joints back in its axes.
    turn = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]], dtype=float)
    side = posekit.segment(V @ turn.T, F, model)
    assert side["frame"]["up"] == "-X", side["frame"]
    assert np.abs(side["joints"] - joints @ turn.T).max() < 1e-9
    assert (side["triangle_part"] == s["triangle_part"]).all()
    with pytest.raises(posekit.InvalidInput):
        posekit.segment(V @ turn.T, F, up="+Y")  # said to stand along +Y: it does not


def test_register_template_to_subject(f01, model):
    V, F = f01
    TV, TF = model.template
    r = posekit.register(TV, TF, V, F)
    assert r["correspondence"].shape == (F.shape[0],)
    assert 0 <= r["correspondence"].min() and r["correspondence"].max() < TF.shape[0]
    assert r["deformed_source"].shape == TV.shape
    with pytest.raises(posekit.InvalidInput, match="ctffd"):
        posekit.register(TV, TF, V, F, method="magic")
    # One thread or two: the same registration to rounding.
    one = posekit.register(TV, TF, V, F, threads=1)
    assert abs(one["deformed_source"] - r["deformed_source"]).max() < 1e-9
    assert (one["correspondence"] == r["correspondence"]).mean() > 0.999
    with pytest.raises(posekit.IoError, match="nothing.pks"):
        posekit.register(TV, TF, V, F, shape_space="/nonexistent/nothing.pks")


def test_compare_a_mesh_with_its_scan(dataset, f01):
    V, F = f01
    scan = posekit.read_point_cloud(str(dataset / "scans" / "f01" / "rest.pcd")) / 1000.0
    c = posekit.compare(V, F, scan)
    assert c["scan_to_model_mm"].shape == (scan.shape[0],) and c["model_to_scan_mm"].shape == (V.shape[0],)
    # one unit out: the per-point distances and their statistics agree
    covered = c["scan_to_model_mm"][~np.isnan(c["scan_to_model_mm"])]
    assert np.abs(covered).max() == pytest.approx(c["scan_stats"]["max_mm"], rel=1e-6, abs=0.05)
    assert c["scan_stats"]["mean_mm"] < 3 and c["coverage"] > 0.9
    with pytest.raises(posekit.InvalidInput):
        posekit.compare(V, F, scan * 1000.0)  # a scan in mm against a mesh in m
    with pytest.raises(posekit.InvalidInput):
        posekit.compare(V, F, np.zeros((0, 3)))


def test_pose_a_subject(dataset, f01, model):
    V, F = f01
    subject = posekit.Subject(model, V, F)
    assert subject.joints.shape == (15, 3) and subject.triangle_part.shape == (F.shape[0],)
    rest = subject.pose(np.zeros((15, 3)))
    assert np.abs(rest - V).max() < 1e-6
    pose = json.loads((dataset / "subjects" / "f01" / "posed" / "squat_half.json").read_text())["joints"]
    truth, _ = posekit.read_mesh(str(dataset / "subjects" / "f01" / "posed" / "squat_half.ply"))
    posed = subject.pose(pose)
    assert np.linalg.norm(posed - truth, axis=1).mean() < 0.012
    rigid = subject.pose(pose, method="rigid")
    assert np.linalg.norm(rigid - truth, axis=1).mean() > np.linalg.norm(posed - truth, axis=1).mean()
    # A batch, on two threads, is the same as one pose at a time.
    array = np.array([pose[name] for name in posekit.joint_names])
    batch = subject.pose_batch(np.stack([np.zeros((15, 3)), array, 0.5 * array]), threads=2)
    assert batch.shape == (3,) + V.shape
    assert np.abs(batch[1] - posed).max() < 1e-9
    assert np.abs(batch[2] - subject.pose(0.5 * array)).max() < 1e-9
    # Python threads pose at once (the GIL is released).
    results = [None, None]

    def work(i):
        results[i] = subject.pose(array * (i + 1) * 0.5)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert np.abs(results[1] - posed).max() < 1e-9
    # Posekit's own pose files, as they are written: a path (str or pathlib), or the loaded JSON with
    # its format, units and root; the same body as the joints alone (the root is zero here).
    pose_file = dataset / "subjects" / "f01" / "posed" / "squat_half.json"
    assert np.abs(subject.pose(pose_file) - posed).max() < 1e-12
    assert np.abs(subject.pose(str(pose_file)) - posed).max() < 1e-12
    assert np.abs(subject.pose(json.loads(pose_file.read_text())) - posed).max() < 1e-12
    moved = json.loads(pose_file.read_text())
    moved["root_translation"] = [0.1, 0.0, 0.0]
    assert np.abs(subject.pose(moved) - posed - [0.1, 0.0, 0.0]).max() < 1e-9
    # The same body in millimetres, Z up: posed in posekit's axes of the body, given back in the file's.
    to_file = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], dtype=float)
    z_up = posekit.Subject(model, 1000.0 * V @ to_file.T, F)
    assert z_up.frame["unit"] == "mm" and z_up.frame["up"] == "+Z"
    assert np.abs(z_up.pose(pose_file) - 1000.0 * posed @ to_file.T).max() < 1e-6
    assert np.abs(z_up.joints - 1000.0 * subject.joints @ to_file.T).max() < 1e-6
    # Picklable, to go to worker processes: the model as its file's bytes, the subject set up again.
    again = pickle.loads(pickle.dumps(z_up))
    assert np.abs(again.pose(pose_file) - z_up.pose(pose_file)).max() < 1e-12
    assert again.frame == z_up.frame
    with pytest.raises(posekit.IoError, match="nowhere.json"):
        subject.pose(dataset / "nowhere.json")
    with pytest.raises(posekit.InvalidInput, match="left_elbw"):
        subject.pose({"left_elbw": [0, 0, 1]})
    with pytest.raises(posekit.InvalidInput, match="NaN"):
        subject.pose(np.full((15, 3), np.nan))
    with pytest.raises(posekit.InvalidInput, match="15 x 3"):
        subject.pose(np.zeros((14, 3)))
    with pytest.raises(posekit.InvalidInput, match="k x 15 x 3"):
        subject.pose_batch(np.zeros((2, 15)))
    with pytest.raises(posekit.InvalidInput):
        posekit.Subject(model, V[:100], F[:10])


def _motions_dir():
    data = os.environ.get("POSEKIT_DATA") or str(pathlib.Path(__file__).resolve().parents[3] / "shared" / "datasets" / "makehuman")
    return pathlib.Path(data).parent / "motions"


def test_bvh_in_python_is_the_clis(tmp_path, dataset, model):
    """read_poses + Subject.pose_batch against `posekit pose --pose x.bvh`, and read_poses without a
    subject against `posekit retarget`: the same library functions, the same results."""
    cli = os.environ.get("POSEKIT_CLI") or shutil.which("posekit")
    bvh = _motions_dir() / "cmu" / "01_01.bvh"
    rest = dataset / "subjects" / "f01" / "rest.ply"
    model.save(tmp_path / "m.pkm")
    subprocess.run([cli, "pose", "--model", str(tmp_path / "m.pkm"), "--subject", str(rest), "--pose", str(bvh), "--frames", "100:104",
                    "--out", str(tmp_path / "p.ply")], check=True, capture_output=True)
    subject = posekit.Subject(model, *posekit.read_mesh(rest))
    sequence = posekit.read_poses(bvh, subject=subject, frames=(100, 104))
    assert [p["name"] for p in sequence["poses"]] == ["01_01_0100", "01_01_0101", "01_01_0102", "01_01_0103"]
    assert any("pelvis=Hips" in note for note in sequence["notes"]), sequence["notes"]
    posed = subject.pose_batch(sequence["poses"], threads=2)
    # The walk's root motion came through: a root translation per frame, the body moved by it.
    assert sequence["poses"][3]["root_translation"] != sequence["poses"][0]["root_translation"]
    assert np.abs(posed[3].mean(axis=0) - posed[0].mean(axis=0)).max() > 3e-4
    for i in range(4):
        by_cli, _ = posekit.read_mesh(tmp_path / f"p_{i:04d}.ply")
        assert np.abs(by_cli - posed[i]).max() < 2e-6  # the CLI's file holds float32 coordinates
        assert np.abs(subject.pose(sequence["poses"][i]) - posed[i]).max() < 1e-9
    # Without a subject: the default body's joints, as `posekit retarget` writes them.
    subprocess.run([cli, "retarget", str(bvh), "--frames", "100:102", "--out", str(tmp_path / "json")], check=True, capture_output=True)
    default = posekit.read_poses(bvh, frames=(100, 102))["poses"]
    for pose in default:
        written = json.loads((tmp_path / "json" / (pose["name"] + ".json")).read_text())
        assert {k: v for k, v in pose.items() if k != "name"} == written
    assert posekit.read_bvh(bvh)["frames"].shape[0] > 104
    with pytest.raises(posekit.InvalidInput, match="root_motion"):
        posekit.read_poses(bvh, subject=subject, frames=(0, 2), root_motion="sideways")
    with pytest.raises(posekit.Error, match="frames"):
        posekit.read_poses(bvh, subject=subject, frames=(0, 100000))


def test_fit_a_subject_to_a_scan_and_to_its_registered_mesh_as_the_cli(tmp_path, dataset, model):
    cli = os.environ.get("POSEKIT_CLI") or shutil.which("posekit")
    rest = dataset / "subjects" / "f01" / "rest.ply"
    scan = dataset / "scans" / "f01" / "squat_half.pcd"
    model.save(tmp_path / "m.pkm")
    subject = posekit.Subject(model, *posekit.read_mesh(rest))
    by_cli = json.loads(subprocess.run([cli, "fit", "--model", str(tmp_path / "m.pkm"), "--subject", str(rest), "--target", str(scan),
                                        "--json"], check=True, capture_output=True, text=True).stdout)
    points = posekit.read_point_cloud(scan)  # millimetres: the unit is detected as the CLI detects it
    fit = subject.fit(points)
    assert fit["pose"]["joints"] == by_cli["pose"]["joints"] and fit["iterations"] == by_cli["iterations"]
    assert fit["target_to_body_mm"]["mean"] == pytest.approx(by_cli["target_to_body_mm"]["mean"], abs=1e-9)
    assert fit["V"].shape == (subject.faces.max() + 1, 3) and np.abs(fit["V"]).max() > 100  # in the scan's millimetres
    # The subject's own mesh posed: the pose from the correspondences, as fit --registered.
    posed = dataset / "subjects" / "f01" / "posed" / "squat_half.ply"
    by_cli = json.loads(subprocess.run([cli, "fit", "--registered", "--model", str(tmp_path / "m.pkm"), "--subject", str(rest),
                                        "--target", str(posed), "--json"], check=True, capture_output=True, text=True).stdout)
    registered = subject.fit(posekit.read_mesh(posed)[0], registered=True)
    assert registered["pose"]["joints"] == by_cli["pose"]["joints"]
    assert registered["posed_to_target_mm"]["mean"] == pytest.approx(by_cli["posed_to_target_mm"]["mean"], abs=1e-9)
    with pytest.raises(posekit.InvalidInput, match="registered"):
        subject.fit(points[:100], registered=True)


def test_body_model_fit_gives_the_clis_parts_and_joints_in_any_frame(tmp_path, dataset, body_model_file):
    cli = os.environ.get("POSEKIT_CLI") or shutil.which("posekit")
    rest = dataset / "subjects" / "f01" / "rest.ply"
    subprocess.run([cli, "segment", str(rest), "--body-model", str(body_model_file), "--joints", str(tmp_path / "j.json")], check=True,
                   capture_output=True)
    by_cli = json.loads((tmp_path / "j.json").read_text())["joints"]
    model = posekit.BodyModel(body_model_file)
    assert model.components > 5
    V, F = posekit.read_mesh(rest)
    fit = model.fit(V, F)
    assert fit["confident"] and fit["target_part"].shape == (V.shape[0],) and fit["target_part"].min() >= 0
    joints = np.array([by_cli[name] for name in posekit.joint_names])
    assert np.abs(fit["joints"] - joints).max() < 1e-9
    # The same body in millimetres, Z up: the joints come back in its unit and axes.
    to_file = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], dtype=float)
    z_up = model.fit(1000.0 * V @ to_file.T, F)
    assert z_up["frame"]["unit"] == "mm"
    assert np.abs(z_up["joints"] - 1000.0 * joints @ to_file.T).max() < 15  # mm: another start, the same body
    with pytest.raises(posekit.BelowConfidence, match="poor"):
        box = np.random.default_rng(1).uniform(size=(3000, 3)) * [0.5, 1.7, 0.3]  # a standing box, no body
        model.fit(box)


def test_customize_by_the_body_model_as_the_cli(tmp_path, dataset, body_model_file):
    cli = os.environ.get("POSEKIT_CLI") or shutil.which("posekit")
    photos = dataset / "photos" / "f01"
    subprocess.run([cli, "customize", "--method", "model", "--body-model", str(body_model_file), "--front", str(photos / "front.png"),
                    "--side", str(photos / "side.png"), "--camera", str(photos / "camera.json"), "--out", str(tmp_path / "cli.ply")],
                   check=True, capture_output=True)
    body = posekit.customize(photos / "front.png", photos / "side.png", camera=photos / "camera.json", method="model",
                             model=posekit.BodyModel(body_model_file))
    by_cli, faces = posekit.read_mesh(tmp_path / "cli.ply")
    assert np.array_equal(body["F"], faces)
    assert np.abs(body["V"] - by_cli).max() < 2e-6  # the CLI's file holds float32
    assert body["photo_agreement"] > 0.8
    with pytest.raises(posekit.InvalidInput, match="BodyModel"):
        posekit.customize(photos / "front.png", photos / "side.png", camera=photos / "camera.json", method="model")
    with pytest.raises(posekit.InvalidInput, match="height"):
        posekit.customize(photos / "front.png", photos / "side.png", method="paper", model="x.pkc")
