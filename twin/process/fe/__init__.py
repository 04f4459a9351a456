"""FE force histories: loading one with its symmetry declared, where the thesis's bug lived (`load`), and the
stand-in history the package ships (`generator`)."""
