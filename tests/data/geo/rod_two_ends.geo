// A 1D rod [0, length] of cells of size h whose both ends are one contact group: the
// probe at one end must find that end only, whatever the rod's length in the scene's
// units (tests/test_units.py). Physical groups: 1 ends (the two end points), 2 body.
DefineConstant[ h = {0.05, Name "Parameters/h"}, length = {1.0, Name "Parameters/length"} ];
Point(1) = {0, 0, 0, h};
Point(2) = {length, 0, 0, h};
Line(1) = {1, 2};
Transfinite Curve{1} = Round(length / h) + 1;
Physical Point("ends", 1) = {1, 2};
Physical Curve("body", 2) = {1};
