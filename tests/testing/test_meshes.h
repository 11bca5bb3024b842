#pragma once
// Small meshes built in code for the tests.
#include "posekit/core/triangle_mesh.h"

namespace posekit::test {

/// Unit cube [0,1]^3, 8 vertices, 12 outward-facing triangles.
TriangleMesh unit_cube();

/// Regular tetrahedron-like closed mesh (4 vertices, 4 outward faces).
TriangleMesh tetrahedron();

/// Open n x n grid in the XZ plane (one boundary loop of 4n edges), 2 n^2 triangles.
TriangleMesh grid(int n);

/// Icosphere of radius r subdivided `levels` times (outward faces).
TriangleMesh icosphere(int levels, double r = 1.0);

}  // namespace posekit::test
