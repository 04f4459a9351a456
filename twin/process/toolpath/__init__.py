"""Tool paths in the sheet frame: the groove U_ID (`groove`), the standard ISF test parts (`shapes`), CAM programs
(`gcode`), and the sheet's placement in the robot base with the reach check of a whole path (`placement`)."""
