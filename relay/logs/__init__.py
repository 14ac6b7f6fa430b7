"""Log lines that stay safe and bounded: no secrets, and a budget for what others send us."""
