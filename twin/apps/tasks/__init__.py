"""Tasks: each `tx200-twin` command as a typed request and result, callable from Python with the CLI's defaults
and errors.

A task module defines a frozen `...Request` (what the user gives, with the command's defaults), a result that is a
`Report` (its summary `lines()`, its JSON `record()`, its `exit_code`) and one function taking the request and
returning the result. The CLI (`twin/cli/`) only parses options into the request and prints the report
(`twin.cli._common.finish`); a script calls the function:

    from twin.apps.tasks.replay import ReplayRequest, replay_task
    report = replay_task(ReplayRequest(run_dir=Path("runs/cell1"), forces="measured"))
    print(report.record()["robot_gap_rms_mm"])

Modules: `base` (the `Report` base), and one per command (`replay`, `identify` with `identify_sheet`, `calibrate`,
`reproduce`, `compensate` with `compensate_part`, `check`, `place`, `path`, `lab` with `lab_dynamic`, `lab_cnc`
and `lab_output`,
`export`, `learn`, `discrepancy`, `sweep`, `robots`, `materials`, ...); `inputs` holds what several tasks
declare alike (the FE history with its symmetry, the ideal path).
"""
