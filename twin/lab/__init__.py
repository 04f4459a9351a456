"""Lab: the virtual lab — the twin plus measurement models (`measure`) and the effects a lab can hide
(`effects`), producing measured runs with a hidden `truth.json`.

Takes a commanded path, a scenario and effects; gives run directories in the run format.
"""
