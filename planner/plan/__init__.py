"""Planning (Sec. 5.2): torque bounds that guarantee a mode over a friction box, the hand
trajectory, the segment planner and the plan file.
"""
