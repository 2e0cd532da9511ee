// A cylinder of radius 0.1 and height 0.3 (OpenCASCADE), tetrahedra of size h.
SetFactory("OpenCASCADE");
DefineConstant[ h = {0.02, Name "Parameters/h"} ];
Cylinder(1) = {0, 0, 0, 0, 0, 0.3, 0.1};
MeshSize{ PointsOf{ Volume{1}; } } = h;
Physical Volume("body", 1) = {1};
