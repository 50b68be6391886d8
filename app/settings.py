"""Service settings from the environment (SCREWSNAKE_*), with embedded defaults."""

from __future__ import annotations

import os
from pathlib import Path

from pydantic import BaseModel, Field


class Settings(BaseModel):
    database_url: str = "sqlite:///./var/screwsnake.db"
    library: Path | None = None  # None: the bundled library
    api_key: str | None = None  # bearer token required for writes when set
    max_running: int = Field(4, ge=1, le=256)  # missions executing at once; the rest queue
    ws_rate: float = Field(10.0, gt=0, le=200)  # state frames per second and client
    ws_queue: int = Field(
        256, ge=8, le=100_000
    )  # undeliverable event frames before a client is dropped

    @classmethod
    def from_env(cls) -> Settings:
        env = os.environ
        data: dict[str, object] = {}
        for field in cls.model_fields:
            key = f"SCREWSNAKE_{field.upper()}"
            if key in env:
                data[field] = env[key]
        return cls.model_validate(data)
