"""The sheet's force on the tool: the `ForceField` seam (`base`) and its registry (`registry`), and the models.

`table` is the groove's per-pass table field on the tables of `pass_tables`; `isf` the height-map model for any
part, its constants `isf_params`, its fit to the groove `isf_calibration` and its sliding direction `sliding`;
`learned` that model with membrane terms fitted to a cell; `aerens` the published steady axial force;
`tool_friction` the tool's sliding friction at reversals.
"""
