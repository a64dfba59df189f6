"""Thin DVC stage entry points: load config, read inputs, call one library function, write outputs."""
