"""The formed part: the sheet as a height map (`heightmap`), the groove's formed profile (`formed_profile`), the
unsupported bottom (`bottom`), the part as a surface (target, design, scan: `surface`), and its springback after
unclamping (`springback`)."""
