// The box 1 x 0.5 x 0.3 of box.geo drawn with the built-in kernel (points, lines, plane
// surfaces, a surface loop), tetrahedra of size h: a volume gmsh gives no measure of,
// which the estimate takes from its plane faces.
DefineConstant[ h = {0.1, Name "Parameters/h"} ];
a = 1; b = 0.5; c = 0.3;
Point(1) = {0, 0, 0, h}; Point(2) = {a, 0, 0, h}; Point(3) = {a, b, 0, h}; Point(4) = {0, b, 0, h};
Point(5) = {0, 0, c, h}; Point(6) = {a, 0, c, h}; Point(7) = {a, b, c, h}; Point(8) = {0, b, c, h};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Line(5) = {5, 6}; Line(6) = {6, 7}; Line(7) = {7, 8}; Line(8) = {8, 5};
Line(9) = {1, 5}; Line(10) = {2, 6}; Line(11) = {3, 7}; Line(12) = {4, 8};
Curve Loop(1) = {1, 2, 3, 4};     Plane Surface(1) = {1};   // z = 0
Curve Loop(2) = {5, 6, 7, 8};     Plane Surface(2) = {2};   // z = c
Curve Loop(3) = {1, 10, -5, -9};  Plane Surface(3) = {3};   // y = 0
Curve Loop(4) = {2, 11, -6, -10}; Plane Surface(4) = {4};   // x = a
Curve Loop(5) = {3, 12, -7, -11}; Plane Surface(5) = {5};   // y = b
Curve Loop(6) = {4, 9, -8, -12};  Plane Surface(6) = {6};   // x = 0
Surface Loop(1) = {1, 2, 3, 4, 5, 6};
Volume(1) = {1};
Physical Surface("bottom", 1) = {1};
Physical Volume("body", 2) = {1};
