// The box [0, width] x [0, width] x [0, length] in tetrahedra of size about h.
// Groups: bottom (z = 0), top (z = length), sides (the four others), body.
DefineConstant[
  h = {0.05, Name "Parameters/h"},
  length = {0.3, Name "Parameters/length"},
  width = {0.1, Name "Parameters/width"}
];
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, width, width, length};
Mesh.MeshSizeMax = h;
Mesh.MeshSizeMin = h;
bottom() = Surface In BoundingBox{-1e-6, -1e-6, -1e-6, width + 1e-6, width + 1e-6, 1e-6};
top() = Surface In BoundingBox{-1e-6, -1e-6, length - 1e-6, width + 1e-6, width + 1e-6, length + 1e-6};
all() = Boundary{ Volume{1}; };
Physical Surface("bottom", 1) = bottom();
Physical Surface("top", 2) = top();
Physical Surface("sides", 3) = all();
Physical Surface("sides", 3) -= {bottom(), top()};
Physical Volume("body", 4) = {1};
