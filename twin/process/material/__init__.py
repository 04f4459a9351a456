"""Sheet materials: the shipped library and name look-up, each number with its source (`library`), a material's
hardening law (`hardening`), and the materials file a user or the library declares (`file`)."""
