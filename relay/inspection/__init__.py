"""Inspection: targets, missions that visit them, captures and findings, their storage and their report."""
