"""Prometheus metrics of one app instance (its own registry: tests create many apps)."""

from __future__ import annotations

from prometheus_client import CollectorRegistry, Counter, Gauge, Histogram


class Metrics:
    def __init__(self) -> None:
        self.registry = CollectorRegistry()
        r = self.registry
        self.created = Counter("screwsnake_missions_created", "Missions accepted", registry=r)
        self.finished = Counter(
            "screwsnake_missions_finished", "Missions ended", ["status"], registry=r
        )
        self.running = Gauge("screwsnake_missions_running", "Missions executing now", registry=r)
        self.queued = Gauge("screwsnake_missions_queued", "Missions waiting for a slot", registry=r)
        self.replan_latency = Histogram(
            "screwsnake_replan_latency_seconds",
            "Replanning latency",
            registry=r,
            buckets=(0.001, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 1, 5),
        )
        self.workers = Gauge("screwsnake_workers", "Mission workers in the pool", registry=r)
        self.workers_warm = Gauge(
            "screwsnake_workers_warm", "Mission workers whose warm-up has ended", registry=r
        )
        self.ws_clients = Gauge("screwsnake_ws_clients", "Connected websocket clients", registry=r)
        self.frames_sent = Counter("screwsnake_ws_frames_sent", "Websocket frames sent", registry=r)
        self.frames_dropped = Counter(
            "screwsnake_ws_frames_dropped", "State frames superseded (latest wins)", registry=r
        )
        self.clients_dropped = Counter(
            "screwsnake_ws_clients_dropped", "Clients dropped for falling behind", registry=r
        )
        self.jobs = Counter(
            "screwsnake_learning_jobs", "Learning jobs ended", ["status"], registry=r
        )
