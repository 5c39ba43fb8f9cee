"""Scene builders: the paper's examples, the ruler of Sec. 5.1 and two-finger hands.
"""
