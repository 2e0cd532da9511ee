// An elastic ball of radius `width` centred at (0, 0, 1.05 width): unstructured
// tetrahedra of size about h, its surface width/20 above the obstacle plane z = 0 (a gap
// that scales with the ball: 0.01 at the scene's width 0.2, the same double as 0.2 + 0.01).
// Physical groups: 1 surface (the whole sphere: the contact boundary), 2 body.
// The parameters h and width (and length, unused) are those of the scene's &mesh when a
// scene names this file, as `gmsh -3 -setnumber h 0.05 ball.geo` would set them.

SetFactory("OpenCASCADE");
DefineConstant[
  h = {0.05, Min 1e-4, Max 1, Name "Parameters/h"},
  length = {1.0, Name "Parameters/length"},
  width = {0.2, Name "Parameters/width"}
];

Sphere(1) = {0, 0, 1.05 * width, width};
MeshSize{ PointsOf{ Volume{1}; } } = h;
Mesh.MeshSizeMax = h;

Physical Surface("surface", 1) = {1};
Physical Volume("body", 2) = {1};
