"""Learning jobs: start one, follow its progress, cancel it."""

from __future__ import annotations

from fastapi import APIRouter, Depends, Response

from app.api.deps import JobId, Svc, writer
from app.api.errors import ApiError, responses
from app.api.schemas import JobOut, LearnIn
from app.api.validated import ValidatedRoute
from app.store.models import JobRow

router = APIRouter(tags=["jobs"], route_class=ValidatedRoute)  # bodies off the loop


def job_out(row: JobRow) -> JobOut:
    return JobOut(
        id=row.id,
        kind=row.kind,
        status=row.status,
        reason=row.reason,
        created_at=row.created_at,
        request=row.request,
        progress=row.progress,
        result=row.result,
    )


@router.post(
    "/jobs/learn",
    status_code=202,
    response_model=JobOut,
    dependencies=[Depends(writer)],
    responses=responses(401, 422, 503),
)
def start_learning(body: LearnIn, response: Response, svc: Svc) -> JobOut:
    job_id = svc.jobs.start(body.model_dump(mode="json"))
    response.headers["Location"] = f"/jobs/{job_id}"
    row = svc.store.get_job(job_id)
    assert row is not None
    return job_out(row)


@router.get("/jobs/{job_id}", response_model=JobOut, responses=responses(404))
def get_job(job_id: JobId, svc: Svc) -> JobOut:
    row = svc.store.get_job(job_id)
    if row is None:
        raise ApiError(404, f"job {job_id} not found")
    return job_out(row)


@router.post(
    "/jobs/{job_id}/cancel",
    status_code=202,
    response_model=JobOut,
    dependencies=[Depends(writer)],
    responses=responses(401, 404, 409),
)
def cancel_job(job_id: JobId, svc: Svc) -> JobOut:
    row = svc.store.get_job(job_id)
    if row is None:
        raise ApiError(404, f"job {job_id} not found")
    if not svc.jobs.cancel(job_id):
        raise ApiError(409, f"job {job_id} already ended ({row.status})")
    again = svc.store.get_job(job_id)
    assert again is not None
    return job_out(again)
