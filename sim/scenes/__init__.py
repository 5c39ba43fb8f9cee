"""Scene builders: any system file (one or several workpieces, fingertips, chains, environment
surfaces: ``system``), a hand at a configuration (``hand``), the ruler of Sec. 5.1 (``ruler``),
and their shared shapes (``shapes``)."""
