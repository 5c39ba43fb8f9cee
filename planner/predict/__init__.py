"""Prediction (Sec. 3.2-3.3): kinematic and force stages with certificates, feasibility of
every mode (eqs. 13-32), force-indeterminate modes (relaxed utility) and the exact pruned search.
"""
