"""The workpiece-contact model (Sec. 3): frozen System/Contact/JointControl, contact modes,
manipulator kinematics and hand geometry. Lowest layer of the library.
"""
