#!/usr/bin/env python3
"""Writes the interop corpus: files in the shapes other software writes and posekit once misread or
dropped (Blender-style OBJ normals, partial OBJ colours, short and extra BVH frame lines, a PLY whose
faces come before its vertices, PLY face properties and MeshLab's per-corner texcoord, diffuse_*
colours, RGBA in XYZ, empty clouds). Fetches nothing: every file is generated here, with what an
independent reader (this script, which wrote it) expects of it in OUT/expected.json.

usage: scripts/interop-corpus.py OUT_DIR

expected.json maps each file name to:
  "outcome": "reads" or "refused"
  "message": for refused files, a part of the error posekit must print
  "warning": for files read with a caveat, a part of the warning posekit must print
  "kind": "mesh" or "cloud" (as `posekit info` reports it); "vertices", "faces": counts
  "normals", "colours": per-vertex lists when the file's fields must be kept exactly so
  "face_fields": {name: per-triangle values}; "uv": per-vertex texture coordinates
  "frames": the frame count of a BVH file
"""
import json
import math
import os
import struct
import sys


def tetrahedron():
    v = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]
    c = [sum(p[k] for p in v) / 4 for k in range(3)]
    n = []
    for p in v:
        d = [p[k] - c[k] for k in range(3)]
        length = math.sqrt(sum(x * x for x in d))
        n.append(tuple(round(x / length, 6) for x in d))
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    return v, n, faces


def blender_obj(out, expected):
    """Normals written in another order than the vertices, paired by the faces' v//vn."""
    v, n, faces = tetrahedron()
    vn_of_vertex = [3, 1, 4, 2]  # 1-based vn line of each vertex
    lines = ["# Blender 3.6.0", "mtllib tetra.mtl", "o Tetra"]
    lines += ["v %.6f %.6f %.6f" % p for p in v]
    for line in range(1, 5):
        i = vn_of_vertex.index(line)
        lines.append("vn %.6f %.6f %.6f" % n[i])
    lines += ["usemtl Material", "s 1"]
    for f in faces:
        lines.append("f " + " ".join("%d//%d" % (i + 1, vn_of_vertex[i]) for i in f))
    write(out, "blender_normals.obj", "\n".join(lines) + "\n")
    expected["blender_normals.obj"] = {"outcome": "reads", "kind": "mesh", "vertices": 4, "faces": 4,
                                       "normals": [list(x) for x in n]}
    # Flat shading: every face its own normal, so a vertex has three: not kept, said.
    lines = ["v %.6f %.6f %.6f" % p for p in v]
    for k in range(4):
        lines.append("vn 0 0 %d" % (1 if k % 2 else -1))
    for k, f in enumerate(faces):
        lines.append("f " + " ".join("%d//%d" % (i + 1, k + 1) for i in f))
    write(out, "flat_normals.obj", "\n".join(lines) + "\n")
    expected["flat_normals.obj"] = {"outcome": "reads", "kind": "mesh", "vertices": 4, "faces": 4,
                                    "warning": "normals not kept"}


def partial_colour_obj(out, expected):
    text = "v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0 0 1 0\nv 1 1 0\nv 2 0 0\nf 1 2 3\nf 2 4 3\nf 2 5 4\n"
    write(out, "partial_colours.obj", text)
    expected["partial_colours.obj"] = {"outcome": "reads", "kind": "mesh", "vertices": 5, "faces": 3,
                                       "warning": "vertex colours not kept: only 2 of 5 vertices"}


BVH_HEAD = ("HIERARCHY\nROOT Hips\n{\n\tOFFSET 0 0 0\n\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
            "\tJOINT Spine\n\t{\n\t\tOFFSET 0 10 0\n\t\tCHANNELS 3 Zrotation Xrotation Yrotation\n"
            "\t\tEnd Site\n\t\t{\n\t\t\tOFFSET 0 10 0\n\t\t}\n\t}\n}\nMOTION\nFrames: %d\nFrame Time: 0.0083333\n")


def bvh_files(out, expected):
    frames = [[f, 90 + f, 0, 0, 0, 0, 5 * f, 0, 0] for f in range(4)]
    text = lambda rows: "\n".join(" ".join("%g" % x for x in row) for row in rows) + "\n"
    # One line misses a value and the next has one too many: the same values in all.
    short = [r[:] for r in frames]
    moved = short[1].pop()
    short[2].insert(0, moved)
    write(out, "short_line.bvh", BVH_HEAD % 4 + text(short))
    expected["short_line.bvh"] = {"outcome": "refused", "message": "frame 2 of 4 has 8 values, expected 9"}
    # One frame line more than "Frames:" says (a common exporter off-by-one).
    write(out, "extra_line.bvh", BVH_HEAD % 3 + text(frames))
    expected["extra_line.bvh"] = {"outcome": "reads", "frames": 3,
                                  "warning": "1 frame line(s) after the 3 the header declares"}
    write(out, "missing_line.bvh", BVH_HEAD % 5 + text(frames))
    expected["missing_line.bvh"] = {"outcome": "refused", "message": "declares 5 frames ('Frames: 5'), the file has 4"}
    write(out, "good.bvh", BVH_HEAD % 4 + text(frames))
    expected["good.bvh"] = {"outcome": "reads", "frames": 4}


def ply_header(fmt, elements):
    lines = ["ply", "format %s 1.0" % fmt, "comment written by scripts/interop-corpus.py"]
    for name, count, props in elements:
        lines.append("element %s %d" % (name, count))
        lines += ["property " + p for p in props]
    return "\n".join(lines + ["end_header"]) + "\n"


def ply_files(out, expected):
    verts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0)]
    xyz = ["float x", "float y", "float z"]
    # The faces before the vertices (valid PLY; some exporters write it so).
    head = ply_header("ascii", [("face", 2, ["list uchar int vertex_indices"]), ("vertex", 5, xyz)])
    body = "4 0 1 2 3\n3 1 4 2\n" + "".join("%g %g %g\n" % p for p in verts)
    write(out, "face_first.ply", head + body)
    expected["face_first.ply"] = {"outcome": "reads", "kind": "mesh", "vertices": 5, "faces": 3}
    # The same in binary.
    head = ply_header("binary_little_endian", [("face", 2, ["list uchar int vertex_indices"]), ("vertex", 5, xyz)])
    data = struct.pack("<B4i", 4, 0, 1, 2, 3) + struct.pack("<B3i", 3, 1, 4, 2)
    data += b"".join(struct.pack("<3f", *p) for p in verts)
    write(out, "face_first_binary.ply", head.encode() + data)
    expected["face_first_binary.ply"] = {"outcome": "reads", "kind": "mesh", "vertices": 5, "faces": 3}
    # Face colours and a quality: kept per triangle (the quad's values on both its triangles).
    head = ply_header("ascii", [("vertex", 5, xyz), ("face", 2, ["list uchar int vertex_indices", "uchar red", "uchar green",
                                                                  "uchar blue", "float quality"])])
    body = "".join("%g %g %g\n" % p for p in verts) + "4 0 1 2 3 200 10 20 0.5\n3 1 4 2 5 6 7 -1.25\n"
    write(out, "face_properties.ply", head + body)
    expected["face_properties.ply"] = {"outcome": "reads", "kind": "mesh", "vertices": 5, "faces": 3,
                                       "face_fields": {"red": [200, 200, 5], "green": [10, 10, 6], "blue": [20, 20, 7],
                                                       "quality": [0.5, 0.5, -1.25]}}
    # MeshLab's per-corner texcoord, one per vertex: becomes per-vertex texture coordinates.
    uv = [(0, 0), (1, 0), (1, 1), (0, 1)]
    head = ply_header("ascii", [("vertex", 4, xyz), ("face", 2, ["list uchar int vertex_indices", "list uchar float texcoord"])])
    corners = lambda f: " ".join("%g %g" % uv[i] for i in f)
    body = "".join("%g %g %g\n" % p for p in verts[:4])
    body += "3 0 1 2 6 %s\n3 0 2 3 6 %s\n" % (corners((0, 1, 2)), corners((0, 2, 3)))
    write(out, "corner_texcoord.ply", head + body)
    expected["corner_texcoord.ply"] = {"outcome": "reads", "kind": "mesh", "vertices": 4, "faces": 2,
                                       "uv": [list(map(float, t)) for t in uv]}
    # ... and with a seam (fuze.ply's shape): not kept, said.
    body = "".join("%g %g %g\n" % p for p in verts[:4])
    body += "3 0 1 2 6 %s\n3 0 2 3 6 0.5 0.5 1 1 0 1\n" % corners((0, 1, 2))
    write(out, "corner_texcoord_seam.ply", head + body)
    expected["corner_texcoord_seam.ply"] = {"outcome": "reads", "kind": "mesh", "vertices": 4, "faces": 2,
                                            "warning": "texture coordinates not kept"}
    # diffuse_red/green/blue (some scanners and Open3D's test data): colours, not scalars.
    head = ply_header("ascii", [("vertex", 3, xyz + ["uchar diffuse_red", "uchar diffuse_green", "uchar diffuse_blue"])])
    colours = [(255, 128, 0), (1, 2, 3), (40, 50, 60)]
    body = "".join("%g %g %g %d %d %d\n" % (verts[i] + colours[i]) for i in range(3))
    write(out, "diffuse_colours.ply", head + body)
    expected["diffuse_colours.ply"] = {"outcome": "reads", "kind": "cloud", "vertices": 3,
                                       "colours": [list(c) for c in colours]}
    # No points at all.
    write(out, "empty.ply", ply_header("ascii", [("vertex", 0, xyz)]))
    expected["empty.ply"] = {"outcome": "refused", "message": "no points"}


def xyz_files(out, expected):
    rows = [(0, 0, 0, 255, 0, 10, 255), (1, 0, 0, 0, 200, 20, 255), (0, 1, 0, 30, 40, 50, 255)]
    write(out, "rgba.xyz", "".join("%g %g %g %d %d %d %d\n" % r for r in rows))
    expected["rgba.xyz"] = {"outcome": "reads", "kind": "cloud", "vertices": 3,
                            "colours": [list(r[3:6]) for r in rows], "warning": "column 7 as the scalar field alpha"}


def write(out, name, content):
    mode = "wb" if isinstance(content, bytes) else "w"
    with open(os.path.join(out, name), mode) as f:
        f.write(content)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    expected = {}
    blender_obj(out, expected)
    partial_colour_obj(out, expected)
    bvh_files(out, expected)
    ply_files(out, expected)
    xyz_files(out, expected)
    with open(os.path.join(out, "expected.json"), "w") as f:
        json.dump(expected, f, indent=1, sort_keys=True)
    print("interop corpus: %d files in %s" % (len(expected), out))


if __name__ == "__main__":
    main()
