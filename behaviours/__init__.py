"""py_trees behaviours and decorators. They read and write the blackboard only (mission.core.blackboard)."""
