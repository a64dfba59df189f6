"""The shared vocabulary every other package builds on: actions, states and plans with the one
state-transition rule, action results and trajectories, frame names and quaternion helpers,
seed derivations, canonical JSON, and the typed mission record. Imports only the standard
library and numpy (and ``interllm.errors``)."""
