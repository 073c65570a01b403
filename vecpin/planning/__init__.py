"""Planning a laser-tracker campaign: which commands to measure, in which order, and the
files that drive the machine through them (Paper I Section 4 and Fig. 6).

=============================  ==========================================================
:mod:`~vecpin.planning.zones`      axis-space boxes: measurement zones and exclusion zones
:mod:`~vecpin.planning.sightline`  line of sight from the tracker to the target past the
                                   machine's own URDF geometry
:mod:`~vecpin.planning.information` whitened parameter Jacobian of a design, its
                                   covariance and the predicted validation error
:mod:`~vecpin.planning.doptimal`   greedy D-optimal choice among candidate commands
:mod:`~vecpin.planning.route`      measurement order (short axis travel) and approach
:mod:`~vecpin.planning.ncprogram`  NC programs (Siemens 840D, Fanuc, plain G-code)
:mod:`~vecpin.planning.ncdialect`  their blocks per dialect (also the sign test's)
:mod:`~vecpin.planning.problem`    the settings and the problem they pose (tracker, nests, box)
:mod:`~vecpin.planning.candidates` candidate commands and what removes them
:mod:`~vecpin.planning.plan`       the whole plan in one call
=============================  ==========================================================
"""
