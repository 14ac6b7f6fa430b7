"""The wire: what crosses the WebSocket, typed and checked, with no I/O; it imports nothing of the relay above it.

:mod:`.fields` (fields and error codes), :mod:`.declare` (a client command declared once), :mod:`.table` (the
commands a relay accepts), :mod:`.commands` (the station's own), :mod:`.json_frame` (a bounded text frame),
:mod:`.messages` and :mod:`.descriptions` (server messages), :mod:`.identifiers`, :mod:`.frames` (binary frames).
"""
