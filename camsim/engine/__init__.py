"""The engine: exact step maps and recurrences at the bottom, event location, the rigid and compliant contact solvers, and the event-driven integrator on top."""
