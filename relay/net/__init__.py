"""HTTP and WebSocket on one port, hardened: access, TLS, security headers, connection guards, loop stalls."""
