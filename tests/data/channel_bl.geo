// channel with a cylinder: quad boundary layer on the cylinder and the lower wall
lc = 0.03;
Point(1) = {0, 0, 0, lc}; Point(2) = {2, 0, 0, lc}; Point(3) = {2, 1, 0, lc}; Point(4) = {0, 1, 0, lc};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Point(5) = {0.6, 0.5, 0, lc}; Point(6) = {0.75, 0.5, 0, lc}; Point(7) = {0.6, 0.65, 0, lc};
Point(8) = {0.45, 0.5, 0, lc}; Point(9) = {0.6, 0.35, 0, lc};
Circle(5) = {6, 5, 7}; Circle(6) = {7, 5, 8}; Circle(7) = {8, 5, 9}; Circle(8) = {9, 5, 6};
Curve Loop(1) = {1, 2, 3, 4}; Curve Loop(2) = {5, 6, 7, 8};
Plane Surface(1) = {1, 2};
Physical Curve("wall") = {1, 5, 6, 7, 8};
Physical Surface("fluid") = {1};
Field[1] = BoundaryLayer;
Field[1].CurvesList = {1, 5, 6, 7, 8};
Field[1].PointsList = {1, 2};
Field[1].Size = 1.5e-3;
Field[1].Ratio = 1.25;
Field[1].Thickness = 0.05;
Field[1].Quads = 1;
BoundaryLayer Field = 1;
