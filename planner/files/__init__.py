"""The file layer: one JSON reader, atomic writes, and the system / hand / plan formats.
"""
