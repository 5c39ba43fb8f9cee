"""Planning (Sections 3.2 and 5.2): the plan model (:mod:`planner.plan.model`), the segment
planner for any number of effort-controlled joints (:mod:`planner.plan.segment_planner`), the task
search (:mod:`planner.plan.task`), hand files to plans (:mod:`planner.plan.hand_planner`), and
plan files (:mod:`planner.plan.plan_file`).
"""
