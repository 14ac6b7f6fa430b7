"""An arm on a mobile robot, moved by the operator's hand: its URDF chain, kinematics, safety rules, simulated arm."""
