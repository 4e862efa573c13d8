"""Motion-level feasibility Fea^m(y_r, y_o): Drake IK and collision queries under uncertainty."""
