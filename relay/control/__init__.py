"""Who may move a robot, and every path that stops one: leases, the deadman, estops, the motion gate."""
