"""Friction space (Sec. 4): mu-space maps, closed-form region boundaries and the graphical
test of Brost and Mason.
"""
