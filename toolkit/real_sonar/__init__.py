"""Real NXT sonar data: sweep sets taken at known waypoints (`sweeps`), the sonar model fitted and scored
on them (`fit`), their figures (`plots`) and how well one sweep tells its waypoint (`margins`)."""
