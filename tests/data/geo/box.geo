// A box 1 x 0.5 x 0.3 (OpenCASCADE), tetrahedra of size h: the estimate's calibration.
SetFactory("OpenCASCADE");
DefineConstant[ h = {0.1, Name "Parameters/h"} ];
Box(1) = {0, 0, 0, 1, 0.5, 0.3};
MeshSize{ PointsOf{ Volume{1}; } } = h;
Physical Volume("body", 1) = {1};
