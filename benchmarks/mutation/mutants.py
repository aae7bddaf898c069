"""The mutation check's table: small, realistic breaks of the learner's state, job and ownership
code, each of a promise its docstrings or docs/ make, applied one at a time by
``benchmarks/mutation/run.py``.

A mutant replaces the text ``find`` (found exactly once in ``file``) by ``replace``. It is
*killed* when the tests that cover its file (:data:`TESTS`) fail with it. A mutant no test can
tell from the code (the same behaviour a user can observe) carries ``equivalent``, the reason; a
survivor without one is a gap in the suite. ``issue`` names the break of issue 67 a mutant is.
The scope (:data:`SCOPE`) is services/learner/{core,store,runner,ownership}.py; the rows of
services/learner/service.py (the ownership checks of issue 67, breaks 6 and 7) are run and
reported beside it.

Why a hand-kept table and not a tool's every mutant: mutmut 3.8.1 generates 2,532 mutants for the
four files (most of them changes of log and error strings); at the 10-45 s their covering tests
take per mutant on this 2-core machine that is 7 to 30 hours per run (benchmarks/results/mutation.json
records the count and how it was taken).
"""
from __future__ import annotations

from dataclasses import dataclass

CORE, STORE, RUNNER, OWNERSHIP, SERVICE = (f"services/learner/{m}.py" for m in
                                          ("core", "store", "runner", "ownership", "service"))
#: The files whose mutation score is published.
SCOPE = (CORE, STORE, RUNNER, OWNERSHIP)

_LEARNER = "tests/unit/services/learner/"
#: The tests run against a mutant of each file, in this order (pytest stops at the first failure,
#: so the likeliest killers come first): the tests written for that module, not the whole suite.
TESTS: dict[str, tuple[str, ...]] = {
    CORE: tuple(_LEARNER + f for f in ("test_core.py", "test_durability.py", "test_journal.py", "test_state_faults.py",
                                       "test_bootstrap.py", "test_limits.py", "test_metrics.py", "test_ownership.py",
                                       "test_concurrent_jobs.py")),
    STORE: tuple(_LEARNER + f for f in ("test_state_faults.py", "test_durability.py", "test_core.py", "test_journal.py",
                                        "test_bootstrap.py", "test_limits.py", "test_metrics.py", "test_ownership.py",
                                        "test_concurrent_jobs.py")),
    RUNNER: (_LEARNER + "test_concurrent_jobs.py", _LEARNER + "test_core.py"),
    OWNERSHIP: (_LEARNER + "test_ownership.py", "tests/unit/clients/commands/test_up.py",
                "tests/e2e/test_several_learners.py"),
    SERVICE: ("tests/e2e/test_several_learners.py",),
}


@dataclass(frozen=True)
class Mutant:
    """One break: ``find`` -> ``replace`` in ``file``; ``breaks`` the promise it breaks."""

    id: str
    file: str
    find: str
    replace: str
    breaks: str
    issue: int | None = None
    equivalent: str | None = None


MUTANTS: tuple[Mutant, ...] = (
    # ----- core.py: jobs, cancel, pruning, version numbers --------------------------------------
    Mutant("core-cancel-finished", CORE,
           "            if job.state in TERMINAL:\n                return job.status()",
           "            if False:\n                return job.status()",
           "a finished job stays as it ended when cancelled", issue=2),
    Mutant("core-job-record-versions-ignored", CORE,
           "                    self.skill_store.note_version(job.skill, version, f\"job {job.job}\")",
           "                    pass",
           "a version a job record names is never given again", issue=5),
    Mutant("core-prune-keeps-one-more", CORE,
           "len(recent) - self.limits.keep_finished_jobs)]",
           "len(recent) - self.limits.keep_finished_jobs - 1)]",
           "exactly --keep-jobs finished records are kept", issue=9),
    Mutant("core-prune-age-ignored", CORE,
           "old = [j for j in finished if (j.updated or j.created) < cutoff]",
           "old = []",
           "finished records are removed --keep-job-days after their last change"),
    Mutant("core-queue-bound-off-by-one", CORE,
           "if sum(j.state in UNFINISHED for j in self.jobs.values()) >= limit:",
           "if sum(j.state in UNFINISHED for j in self.jobs.values()) > limit:",
           "at most --max-queued-jobs unfinished jobs; the next is refused busy"),
    Mutant("core-restart-same-attempt", CORE,
           'self._persist(job, attempt=job.attempt + 1, state="queued")',
           'self._persist(job, state="queued")',
           "a job running at a crash restarts under a new attempt number"),
    Mutant("core-commit-without-success", CORE,
           "if req.commit and job.result.success:",
           "if req.commit:",
           "only a successful solution is assimilated into a new version"),
    Mutant("core-assimilated-twice", CORE,
           "do not add it twice\n                return",
           "do not add it twice",
           "a job whose assimilation was committed before a crash is not assimilated again"),
    Mutant("core-assimilates-unadapted-copy", CORE,
           "self._assimilate(job, model if current is not None and current.version == start_version else None)",
           "self._assimilate(job, None)",
           "the committed version is the adapted model trained on with its solution"),
    Mutant("core-memory-before-disk", CORE,
           "            self.job_store.save(new)\n            for name in changes:\n"
           "                setattr(job, name, getattr(new, name))",
           "            for name in changes:\n                setattr(job, name, getattr(new, name))\n"
           "            self.job_store.save(new)",
           "a change to a job is made in memory only once its write returned"),
    Mutant("core-accepted-before-durable", CORE,
           "            self.job_store.save(job)\n            self.jobs[job.job] = job",
           "            self.jobs[job.job] = job\n            self.job_store.save(job)",
           "a job is accepted only once its record is on disk"),
    Mutant("core-no-journal", CORE,
           "            self.journals.save(job.job, events)",
           "            pass",
           "a batch's roll-out events are journalled before their indices are reserved"),
    Mutant("core-indices-overlap", CORE,
           "self._persist(job, next_index=first + len(batch),",
           "self._persist(job, next_index=first + len(batch) - 1,",
           "roll-out indices are never used twice"),
    Mutant("core-journal-indices-not-reserved", CORE,
           "            if job is not None and job.next_index < top:",
           "            if job is None:",
           "a journal's indices count as reserved at a start"),
    Mutant("core-newest-job-first", CORE,
           "for job in self.jobs.values():  # in the order they were queued",
           "for job in reversed(list(self.jobs.values())):  # in the order they were queued",
           "jobs run in the order they were queued"),
    Mutant("core-terminal-state-not-retried", CORE,
           "if state not in TERMINAL or self._stop.is_set():",
           "if True:",
           "a job's terminal record is written however long the disk refuses it"),
    Mutant("core-running-job-cancelled-at-once", CORE,
           "now = job.job not in self._active",
           "now = True",
           "a running job ends cancelled after its iteration in flight, not at once"),
    Mutant("core-train-reuses-version", CORE,
           "SkillState(skill, model, spec.demos, self.skill_store.next_version(skill),",
           "SkillState(skill, model, spec.demos, max(0, self.skill_store.highest(skill)),",
           "a training commits the skill's next version"),
    Mutant("core-shutdown-fails-job", CORE,
           '            log.info("job %s interrupted by shutdown", job_id)\n            self._finish(job_id, "interrupted")',
           '            log.info("job %s interrupted by shutdown", job_id)\n            self._finish(job_id, "failed")',
           "a job running at a SIGTERM is saved interrupted and resumes"),

    # ----- store.py: versions, quarantine, commits -----------------------------------------------
    Mutant("store-versions-from-file-names-only", STORE,
           "        used = [v for v in files] + [int(m.group(2)) for m in map(_VERSIONED.match, "
           "self.state.quarantined_names(rel_dir))\n                                     if m]\n"
           "        for v in used:\n            self.note_version(name, v)\n        if recorded is not None:",
           "        used = [v for v in files]\n        for v in used:\n            self.note_version(name, v)\n"
           "        if False:",
           "a plain restart after a quarantine never reuses a version number", issue=3),
    Mutant("store-quarantined-names-ignored", STORE,
           "        used = [v for v in files] + [int(m.group(2)) for m in map(_VERSIONED.match, "
           "self.state.quarantined_names(rel_dir))\n                                     if m]",
           "        used = [v for v in files]",
           "a quarantined version's number is never given again", issue=4),
    Mutant("store-version-record-ignored", STORE,
           "        if recorded is not None:\n            self.note_version(name, recorded, VERSIONS_FILE)",
           "        if False:\n            self.note_version(name, recorded, VERSIONS_FILE)",
           "versions.json's high-water mark is never given again"),
    Mutant("store-version-record-not-written", STORE,
           "        self.note_version(skill.name, v)\n        self._write_versions(d, skill.name)",
           "        self.note_version(skill.name, v)",
           "a commit updates versions.json"),
    Mutant("store-keeps-one-more-version", STORE,
           "reverse=True)[:self.keep_versions]",
           "reverse=True)[:self.keep_versions + 1]",
           "exactly --keep-versions checkpoints are kept per skill"),
    Mutant("store-failed-commit-leaves-files", STORE,
           "                    path.unlink(missing_ok=True)\n                except OSError:\n"
           '                    log.warning("could not remove %s after a failed commit"',
           "                    pass\n                except OSError:\n"
           '                    log.warning("could not remove %s after a failed commit"',
           "a commit that fails leaves nothing of its version"),
    Mutant("store-checkpoint-version-unchecked", STORE,
           'if meta.get("version") != v or meta.get("skill", name) != name:',
           "if False:",
           "a checkpoint whose content is another version's (or skill's) is quarantined"),
    Mutant("store-demos-hash-unchecked", STORE,
           "        if demos.content_hash() != data_hash:",
           "        if False:",
           "demonstrations that are not those a checkpoint records are quarantined"),
    Mutant("store-committed-demos-removed", STORE,
           "if recorded is not None and v > recorded:",
           "if recorded is not None and v >= recorded:",
           "demonstrations of a committed version whose checkpoint is missing are quarantined, not removed"),
    Mutant("store-serves-oldest-version", STORE,
           "                chosen = self._load_version(d, name, v, files[v])\n                break",
           "                chosen = self._load_version(d, name, v, files[v])",
           "a skill is served at its newest usable version"),
    Mutant("store-quarantine-copies", STORE,
           "                os.replace(path, dest)",
           "                dest.write_bytes(path.read_bytes())",
           "an unusable file is moved aside, not left in place"),
    Mutant("store-job-name-unchecked", STORE,
           "            if job.job != p.stem:",
           "            if False:",
           "a job record under another job's name is quarantined"),
    Mutant("store-write-error-sticky", STORE,
           "        self._write_error = None\n\n    def quarantine",
           "\n    def quarantine",
           "the health reports a failed write only until a write succeeds"),
    Mutant("store-stale-temps-kept", STORE,
           "            self.state.remove_stale_temps(d)\n            state = self._load_skill(d)",
           "            state = self._load_skill(d)",
           "temp files of dead writers are removed at a start"),
    Mutant("store-bad-journal-kept", STORE,
           '            self.state.quarantine(path, f"not a roll-out journal ({exc})")',
           "            pass",
           "an unreadable roll-out journal is quarantined"),

    # ----- runner.py: jobs in child processes ------------------------------------------------
    Mutant("runner-weights-not-returned", RUNNER,
           "                    task.model.load_state_dict(weights)",
           "                    pass",
           "a job run in a child process commits the weights it adapted", issue=1),
    Mutant("runner-child-ignores-seed", RUNNER,
           "seed=task.seed, on_iteration=lambda *args: _ask(conn, (\"iteration\", args)))",
           "seed=0, on_iteration=lambda *args: _ask(conn, (\"iteration\", args)))",
           "a job's result does not depend on the runner (its seed decides)"),
    Mutant("runner-child-death-unexplained", RUNNER,
           "raise ChildDied(f\"the job's adaptation process ended (exit code {code})\") from None",
           "raise RuntimeError(\"adaptation failed\") from None",
           "a job whose adaptation process dies fails with a line saying so"),
    Mutant("runner-cancel-not-sent-to-child", RUNNER,
           '                    pending, answer = exc, ("raise", exc)',
           '                    pending, answer = None, ("value", None)',
           "a cancel or shutdown raised by the parent stops the child's adaptation"),
    Mutant("runner-thread-records-nothing", RUNNER,
           "                     on_iteration=on_iteration)",
           "                     on_iteration=None)",
           "every iteration of a job on a thread is recorded"),
    Mutant("runner-process-is-a-thread", RUNNER,
           "        return ProcessRunner(name)",
           "        return ThreadRunner()",
           "--job-runner process computes jobs in child processes"),

    # ----- ownership.py: which learner answers ----------------------------------------------
    Mutant("ownership-dead-owner-dropped", OWNERSHIP,
           'return "drop" if owner in self._live else owner',
           'return "drop"',
           "a dead owner's skills are answered unavailable naming it", issue=7),
    Mutant("ownership-min-hash", OWNERSHIP,
           "    return max(learners, key=lambda lid:",
           "    return min(learners, key=lambda lid:",
           "every learner computes the same owner; removing one moves only its skills",
           equivalent="the lowest hash is as much a rendezvous hash as the highest: every learner computes "
                      "the same owner, skills spread alike and removing a learner moves only its own; a "
                      "deployment's owners would differ from a learner of the other rule, but every learner "
                      "of one deployment runs the same code"),
    Mutant("ownership-job-skill-first-dash", OWNERSHIP,
           'skill, sep, _ = job.rpartition("-")',
           'skill, sep, _ = job.partition("-")',
           "a job of a skill with a dash in its name reaches the skill's owner"),
    Mutant("ownership-repeated-id-accepted", OWNERSHIP,
           "    if len(set(ids)) != len(ids):",
           "    if False:",
           "--learners refuses an id given twice"),
    Mutant("ownership-self-not-listed-accepted", OWNERSHIP,
           "        if self.learners and me not in self.learners:",
           "        if False:",
           "a learner whose id is not in --learners refuses to start"),
    Mutant("ownership-first-learner-moves", OWNERSHIP,
           'return state_dir if learner == learners[0] else state_dir / "learners" / learner',
           'return state_dir / "learners" / learner',
           "the first learner keeps the deployment's state directory (one learner grown to several "
           "keeps its skills)"),
    Mutant("ownership-own-token-dropped", OWNERSHIP,
           "            elif learner != self.me:",
           "            else:",
           "a learner counts itself live",
           equivalent="a learner's own token goes only in LearnerService.close, after its queryables are "
                      "undeclared: nothing asks it afterwards, and decide() serves its own skills without "
                      "looking at the live set"),
    Mutant("ownership-one-id-not-alone", OWNERSHIP,
           "        return len(self.learners) <= 1",
           "        return len(self.learners) < 1",
           "a learner given only its own id serves every skill",
           equivalent="a one-id list holds this learner's own id (checked at construction), so owner() is "
                      "this learner for every skill either way; only whether its queryables are declared "
                      "complete differs, which no reply shows (and launchers pass --learners only for two "
                      "or more)"),

    # ----- service.py (reported beside the scope): the owner checks of a request -------------
    Mutant("service-status-cancel-any-learner", SERVICE,
           "        self._check_owner(skill_of_job(job))",
           "        if self.ownership.alone:\n            self._check_owner(skill_of_job(job))",
           "with several learners, a job's status and cancel are answered by its skill's owner alone", issue=6),
    Mutant("service-dead-owner-silent", SERVICE,
           '        if decision == "drop":\n            raise NotServed(skill)',
           '        if decision != "serve":\n            raise NotServed(skill)',
           "a dead owner's skills are answered unavailable naming it, not with silence", issue=7),
    Mutant("service-adapt-any-learner", SERVICE,
           '        self._check_owner(skill)\n        msg = require_payload(msg, "an adapt request")',
           '        msg = require_payload(msg, "an adapt request")',
           "with several learners, an adapt request is queued by its skill's owner alone"),
)
