"""People and what they may do: accounts with roles, password hashes, sign-in sessions and headset pairing."""
