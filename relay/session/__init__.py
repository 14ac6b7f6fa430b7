"""A client's session: its frames parsed, rate-limited and carried out, one reply each."""
