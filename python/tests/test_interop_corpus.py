"""The interop corpus (scripts/interop-corpus.py) through the posekit executable: each file read with
every field the script wrote, or refused or warned about as expected. Fields are compared through
`posekit convert FILE x.ply --ascii`, parsed here with a reader of our own."""
import json
import os
import shutil
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def posekit():
    cli = os.environ.get("POSEKIT_CLI") or shutil.which("posekit")
    assert cli, "set POSEKIT_CLI to the posekit executable"
    return cli


def read_ascii_ply(path):
    """{element: [ {property: value or list} ]} of an ascii PLY."""
    with open(path) as f:
        lines = f.read().split("\n")
    assert lines[0] == "ply" and lines[1].startswith("format ascii")
    elements, k = [], 2
    while lines[k] != "end_header":
        t = lines[k].split()
        if t[0] == "element":
            elements.append((t[1], int(t[2]), []))
        elif t[0] == "property":
            elements[-1][2].append((t[-1], t[1] == "list"))
        k += 1
    k += 1
    out = {}
    for name, count, props in elements:
        rows = []
        for _ in range(count):
            values, row, i = lines[k].split(), {}, 0
            k += 1
            for prop, is_list in props:
                if is_list:
                    n = int(values[i])
                    row[prop] = [float(x) for x in values[i + 1:i + 1 + n]]
                    i += 1 + n
                else:
                    row[prop] = float(values[i])
                    i += 1
            assert i == len(values)
            rows.append(row)
        out[name] = rows
    return out


@pytest.fixture(scope="module")
def corpus(tmp_path_factory):
    out = tmp_path_factory.mktemp("interop")
    subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "interop-corpus.py"), str(out)], check=True)
    with open(out / "expected.json") as f:
        return out, json.load(f)


def test_the_corpus_has_every_shape_the_interop_run_found(corpus):
    _, expected = corpus
    for name in ["blender_normals.obj", "partial_colours.obj", "short_line.bvh", "extra_line.bvh", "face_first.ply",
                 "face_properties.ply", "corner_texcoord.ply", "diffuse_colours.ply", "rgba.xyz", "empty.ply"]:
        assert name in expected


def test_every_file_reads_with_its_fields_or_is_refused_naming_it(corpus, tmp_path):
    folder, expected = corpus
    for name, want in sorted(expected.items()):
        path = str(folder / name)
        info = subprocess.run([posekit(), "info", path, "--json"], capture_output=True, text=True)
        if want["outcome"] == "refused":
            assert info.returncode == 1, name
            assert want["message"] in info.stderr, (name, info.stderr)
            assert "internal error" not in info.stderr
            continue
        assert info.returncode == 0, (name, info.stderr)
        assert ("warning" in want) == ("warning:" in info.stderr), (name, info.stderr)
        if "warning" in want:
            assert want["warning"] in info.stderr, (name, info.stderr)
        report = json.loads(info.stdout)
        if name.endswith(".bvh"):
            assert report["frames"] == want["frames"], name
            continue
        assert report["kind"] == ("triangle mesh" if want["kind"] == "mesh" else "point cloud"), name
        assert report["vertices" if want["kind"] == "mesh" else "points"] == want["vertices"], name
        if want["kind"] == "mesh":
            assert report["triangles"] == want["faces"], name
        # info says what is kept, for clouds as for meshes.
        assert report["has_colors"] == ("colours" in want), name
        assert report["has_normals"] == ("normals" in want), name
        if "face_fields" in want:
            assert sorted(report["face_fields"]) == sorted(want["face_fields"]), name
        ply = tmp_path / (name + ".ply")
        subprocess.run([posekit(), "convert", path, str(ply), "--ascii"], check=True, capture_output=True)
        back = read_ascii_ply(str(ply))
        vertices = back["vertex"]
        if "normals" in want:
            for v, n in zip(vertices, want["normals"]):
                assert [v["nx"], v["ny"], v["nz"]] == pytest.approx(n, abs=1e-6), name
        else:
            assert "nx" not in vertices[0], name
        if "colours" in want:
            for v, c in zip(vertices, want["colours"]):
                assert [v["red"], v["green"], v["blue"]] == c, name
        if "uv" in want:
            for v, t in zip(vertices, want["uv"]):
                assert [v["texture_u"], v["texture_v"]] == pytest.approx(t), name
        for field, values in want.get("face_fields", {}).items():
            assert [f[field] for f in back["face"]] == pytest.approx(values), (name, field)
