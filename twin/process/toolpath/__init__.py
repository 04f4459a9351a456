"""Tool paths in the sheet frame: the groove U_ID (`groove`), the standard ISF test parts (`shapes`), CAM programs
(`gcode`, reading blocks; `gcode_programs`, the main program and its subprograms; `gcode_arcs`, G2/G3 as chords;
`gcode_write`, the export), and the sheet's placement in the robot base with the reach check of a whole path (`placement`)."""
