"""The web edge: Starlette app, REST routes, the websocket stream, pydantic schemas."""
