// A disk of radius `width` centred at (0, width + 0.01): unstructured triangles of size
// about h, the lower half arc just above the obstacle y = 0.
// Physical groups: 1 bottom (lower half arc), 2 top (upper half arc), 3 body.
// The parameters h and width (and length, unused) are those of the scene's &mesh when a
// scene names this file, as `gmsh -2 -setnumber h 0.02 disk.geo` would set them.

DefineConstant[
  h = {0.02, Min 1e-4, Max 1, Name "Parameters/h"},
  length = {1.0, Name "Parameters/length"},
  width = {0.1, Name "Parameters/width"}
];

r = width;
yc = width + 0.01;
Point(1) = {0, yc, 0, h};
Point(2) = {r, yc, 0, h};
Point(3) = {0, yc + r, 0, h};
Point(4) = {-r, yc, 0, h};
Point(5) = {0, yc - r, 0, h};

Circle(1) = {2, 1, 3};
Circle(2) = {3, 1, 4};
Circle(3) = {4, 1, 5};
Circle(4) = {5, 1, 2};

Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};

Physical Curve("bottom", 1) = {3, 4};
Physical Curve("top", 2) = {1, 2};
Physical Surface("body", 3) = {1};
