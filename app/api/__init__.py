"""The HTTP and websocket API (the shapes of docs/mission-format.md), one router per resource."""
