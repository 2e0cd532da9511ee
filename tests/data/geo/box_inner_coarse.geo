// The box of box.geo with Mesh.MeshSizeExtendFromBoundary = 0: the points' size h stays on
// the boundary and the interior is coarse (506 tetrahedra at h = 0.03, against 27 050).
SetFactory("OpenCASCADE");
DefineConstant[ h = {0.1, Name "Parameters/h"} ];
Box(1) = {0, 0, 0, 1, 0.5, 0.3};
MeshSize{ PointsOf{ Volume{1}; } } = h;
Physical Volume("body", 1) = {1};
Mesh.MeshSizeExtendFromBoundary = 0;
