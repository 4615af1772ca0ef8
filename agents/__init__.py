"""Agents for the shieldnav environments: the scripted inspection stack, SB3 training, the benchmark."""
