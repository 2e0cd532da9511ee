// A cylinder of radius 100 and height 50 drawn in mm (OpenCASCADE), without mesh sizes:
// meshed at a scene's h meant in m it asks gmsh for some 1e11 tetrahedra.
SetFactory("OpenCASCADE");
Cylinder(1) = {0, 0, 10, 0, 0, 50, 100};
Physical Surface("surface", 1) = {1, 2, 3};
Physical Volume("body", 2) = {1};
