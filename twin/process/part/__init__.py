"""The formed part: the sheet as a height map (`heightmap`), the groove's formed profile (`formed_profile`), the
unsupported bottom (`bottom`), the part as a surface (target, design, scan: `surface`), its springback after
unclamping (`springback`) and the wall's tilt when the tool's load is released (`wall_tilt`)."""
