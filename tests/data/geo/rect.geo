// A rectangle 1 x 0.3 of the built-in kernel, unstructured triangles of size h.
DefineConstant[ h = {0.05, Name "Parameters/h"} ];
Point(1) = {0, 0, 0, h}; Point(2) = {1, 0, 0, h};
Point(3) = {1, 0.3, 0, h}; Point(4) = {0, 0.3, 0, h};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Physical Curve("bottom", 1) = {1};
Physical Surface("body", 2) = {1};
