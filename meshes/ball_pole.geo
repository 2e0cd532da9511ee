// An elastic ball of radius `width` centred at (0, 0, width), its south pole (a mesh node)
// on the obstacle plane z = 0: a drop touches at t = 0. Unstructured tetrahedra of size h
// within the distance `length` of the south pole, growing linearly to width/4 (the size
// of meshes/ball.geo at its scene's h = 0.05) at `length` + 0.4 width from it and beyond:
// a ball refined where it touches, coarse elsewhere, for the comparison with Hertz's
// impact (docs/numerics.md, 3D, "Hertz's impact where Hertz holds"). Set `length` to a
// few patch radii (default 0.06: 3 patch radii of an impact with a/R = 0.1).
// Physical groups: 1 surface (the whole sphere: the contact boundary), 2 body.
// The parameters h, length and width are those of the scene's &mesh when a scene names
// this file, as `gmsh -3 -setnumber h 0.005 ball_pole.geo` would set them.
// Among gmsh's options only Mesh.MeshSizeMax is set (the reader restores it): the size is
// the smaller of the points' (coarse) and the background field's (fine near the pole).

SetFactory("OpenCASCADE");
DefineConstant[
  h = {0.005, Min 1e-4, Max 1, Name "Parameters/h"},
  length = {0.06, Name "Parameters/length"},
  width = {0.2, Name "Parameters/width"}
];

coarse = width / 4;
Sphere(1) = {0, 0, width, width};
MeshSize{ PointsOf{ Volume{1}; } } = coarse;
Mesh.MeshSizeMax = coarse;

// the distance to the south pole (0, 0, 0)
Field[1] = MathEval;
Field[1].F = "Sqrt(x * x + y * y + z * z)";
Field[2] = Threshold;
Field[2].InField = 1;
Field[2].SizeMin = h;
Field[2].SizeMax = coarse;
Field[2].DistMin = length;
Field[2].DistMax = length + 0.4 * width;
Background Field = 2;

Physical Surface("surface", 1) = {1};
Physical Volume("body", 2) = {1};
