"""The HTTP and websocket API (DESIGN §10), one router per resource."""
