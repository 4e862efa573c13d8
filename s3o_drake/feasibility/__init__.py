"""Motion-level feasibility Fea^m(y_r, y_o): the probability that the executed pickup succeeds,
from Drake IK and collision queries under the noise (the oracle) or learned (the FCN), with
the FCN's dataset and training."""
