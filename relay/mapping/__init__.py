"""The live 3D map at run time (issue #33): clouds fused off the loop, kept in a file, streamed by version."""
