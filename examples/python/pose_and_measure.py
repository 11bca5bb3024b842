"""Measures a customized body, then poses it with a trained model (numpy in and out).

    PYTHONPATH=<prefix>/lib/python3/dist-packages python3 pose_and_measure.py model.pkm subject.ply
"""
import sys

import numpy as np
import posekit

model = posekit.PoseModel.load(sys.argv[1])
V, F = posekit.read_mesh(sys.argv[2])  # metres, Y up, facing +Z

m = posekit.measure(V, F)
print(f"stature {100 * m['stature']:.1f} cm")
for name, g in m["girths"].items():
    print(f"  {name:10s}", f"{100 * g['value']:6.1f} cm" if g["measured"] else "not measured: " + g["note"])

subject = posekit.Subject(model, V, F)
pose = np.zeros((len(posekit.joint_names), 3))  # axis-angle per joint, relative to its parent part
pose[posekit.joint_names.index("left_shoulder")] = [0, 0, 0.8]   # arm raised sideways
pose[posekit.joint_names.index("right_knee")] = [1.2, 0, 0]      # knee bent
posed = subject.pose(pose)
posekit.write_mesh("posed.ply", posed, F)
print(f"posed {len(V)} vertices: moved up to {100 * np.linalg.norm(posed - V, axis=1).max():.1f} cm; wrote posed.ply")
