"""Running missions as a service: the supervisor, the websocket hub and learning jobs."""
