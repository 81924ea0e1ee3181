"""The bottom floor: types, blackboard keys, SE(3), config schema. Imports nothing of ours."""
