// The seed's bar: [0, width] x [0, length], structured triangles of size h.
// Physical groups as the built-in bar and GetFEM's export:
//   1 bottom (y = 0), 2 top (y = length), 3 left (x = 0), 4 right (x = width), 5 body.
// Mesh it with, e.g.,
//   gmsh -2 -setnumber h 0.02 -format msh41 bar2d.geo -o bar2d_h0.02.msh
// or `python -m dyncontact mesh --h 0.02 --out bar2d_h0.02.msh`.
// "AlternateLeft" diagonals (with this corner order) give exactly the triangles of
// GetFEM's regular mesh and of the built-in bar (checked in tests/test_mesh.py).

DefineConstant[
  h = {0.05, Min 1e-4, Max 1, Name "Parameters/h"},
  length = {1.0, Name "Parameters/length"},
  width = {0.1, Name "Parameters/width"}
];

nx = Round(width / h);
ny = Round(length / h);
If (nx < 1)
  nx = 1;
EndIf
If (ny < 1)
  ny = 1;
EndIf

Point(1) = {0, 0, 0, h};
Point(2) = {width, 0, 0, h};
Point(3) = {width, length, 0, h};
Point(4) = {0, length, 0, h};

Line(1) = {1, 2};   // bottom
Line(2) = {4, 3};   // top
Line(3) = {1, 4};   // left
Line(4) = {2, 3};   // right

Curve Loop(1) = {1, 4, -2, -3};
Plane Surface(1) = {1};

Transfinite Curve{1, 2} = nx + 1;
Transfinite Curve{3, 4} = ny + 1;
Transfinite Surface{1} = {1, 2, 3, 4} AlternateLeft;

Physical Curve("bottom", 1) = {1};
Physical Curve("top", 2) = {2};
Physical Curve("left", 3) = {3};
Physical Curve("right", 4) = {4};
Physical Surface("body", 5) = {1};

Mesh.MshFileVersion = 4.1;
Mesh.Binary = 0;
