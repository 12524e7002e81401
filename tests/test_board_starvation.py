"""When the bench waits for a board process on its own clock (`firmware_interface.board_starvation`): the scheduler
states and schedstat figures /proc would show, scripted, against the rule: runnable once a step's frames are
written, and either without a run for STARVED_S or queued for a CPU more than QUEUED_SHARE of the last QUEUED_SPAN_S
of looks (STARVED_S at least); the wait lasts until it sleeps."""

from __future__ import annotations

from firmware_interface.board_starvation import QUEUED_SHARE, QUEUED_SPAN_S, RECHECK_S, STARVED_S, CpuStarvation


class Process:
    """A board process as /proc shows it, on a clock that the bench's polls move on."""

    def __init__(self) -> None:
        self.now = 0.0
        self.state: str | None = "S"
        self.schedule: tuple[int, int, int] | None = (0, 0, 0)  # CPU ns, ns queued, runs
        self.polls: list[float] = []
        self.gets_a_cpu_at = float("inf")
        self.sliced_share = 0.0  # the share of its time queued while it runs in thin slices (0: not sliced)

    def poll(self, timeout_s: float) -> None:
        self.polls.append(timeout_s)
        if self.sliced_share and self.now + timeout_s < self.gets_a_cpu_at:
            self.run_in_slices(self.now + timeout_s, self.sliced_share)
            return
        self.now += timeout_s
        if self.now >= self.gets_a_cpu_at and self.schedule is not None:
            cpu_ns, queued_ns, runs = self.schedule
            self.schedule = (cpu_ns + 200_000, queued_ns, runs + 1)  # it ran, caught up and sleeps
            self.state = "S"

    def run_in_slices(self, until_s: float, queued_share: float) -> None:
        """Runnable throughout, one run a look after `queued_share` of the time since queued."""
        cpu_ns, queued_ns, runs = self.schedule or (0, 0, 0)
        gap_s = until_s - self.now
        self.now, self.state = until_s, "R"
        self.schedule = (cpu_ns + 10_000, queued_ns + int(gap_s * queued_share * 1e9), runs + 1)

    def starvation(self) -> CpuStarvation:
        return CpuStarvation(lambda: self.schedule, lambda: self.state, lambda: self.now)


def test_a_sleeping_or_computing_process_is_never_waited_for():
    board = Process()
    starvation = board.starvation()
    for step in range(100):  # asleep at every look
        board.now = step * 0.004
        starvation.wait_out(board.poll)
    board.state = "R"
    for step in range(100, 200):  # runnable at every look, but it ran between any two, barely queued
        board.now, board.schedule = step * 0.004, (step * 1000, (step - 100) * 40_000, step)  # 1 % queued
        starvation.wait_out(board.poll)
    assert board.polls == [] and starvation.waits == 0 and starvation.figures() is None


def test_a_process_runnable_without_a_run_is_waited_for_from_starved_s_until_it_runs():
    board = Process()
    starvation = board.starvation()
    board.state = "R"
    starvation.wait_out(board.poll)  # the first look: runnable
    board.now = STARVED_S * 0.9
    starvation.wait_out(board.poll)  # not long enough yet
    assert board.polls == []
    board.now, board.gets_a_cpu_at = STARVED_S, 0.1
    starvation.wait_out(board.poll)
    assert starvation.waits == 1 and board.polls and set(board.polls) == {RECHECK_S}
    assert abs(starvation.waited_s - (0.1 - STARVED_S)) <= RECHECK_S  # until its run, to a recheck
    assert starvation.figures() == {"count": 1, "total_s": starvation.waited_s}


def test_a_run_between_looks_starts_the_count_again_and_a_gone_process_is_not_waited_for():
    board = Process()
    starvation = board.starvation()
    board.state = "R"
    starvation.wait_out(board.poll)
    board.now, board.schedule = STARVED_S * 0.6, (5, 0, 1)  # it ran: the stretch without a run begins here
    starvation.wait_out(board.poll)
    board.now = STARVED_S * 1.2  # 0.6 STARVED_S without a run: no wait
    starvation.wait_out(board.poll)
    assert board.polls == []
    board.schedule = None  # gone: the watchdog's business
    board.now = STARVED_S * 3
    starvation.wait_out(board.poll)
    assert board.polls == [] and starvation.waits == 0


def test_a_process_in_thin_slices_is_waited_for_when_its_queued_share_passes_the_bound_over_starved_s_or_more():
    for share, waited in ((QUEUED_SHARE * 0.8, False), (QUEUED_SHARE * 1.2, True), (0.95, True)):
        board = Process()
        board.sliced_share = share
        starvation = board.starvation()
        board.state = "R"
        starvation.wait_out(board.poll)  # the first look: nothing to compare with
        board.run_in_slices(0.004, share)  # a step later it ran, and was queued for `share` of the step
        starvation.wait_out(board.poll)
        assert board.polls == []  # a span under STARVED_S is not judged
        board.run_in_slices(0.008, share)
        board.gets_a_cpu_at = 0.058  # if waited for: it catches up in 50 ms and sleeps
        starvation.wait_out(board.poll)
        assert (starvation.waits == 1) is waited, share
        if waited:  # on through its slices until it caught up and slept, not past it
            assert abs(starvation.waited_s - 0.05) <= RECHECK_S, starvation.waited_s


def test_one_late_wake_up_of_a_few_ms_is_not_waited_for():
    board = Process()
    starvation = board.starvation()
    for step in range(20):  # woken by each step's frame, looked at while it computes; asleep in between
        board.now, board.state = step * 0.004, "R"
        late_ns = 3_000_000 if step == 10 else 0  # one wake-up 3 ms late (a busy neighbour), ~1 % otherwise
        cpu_ns, queued_ns, runs = board.schedule or (0, 0, 0)
        board.schedule = (cpu_ns + 80_000, queued_ns + 40_000 + late_ns, runs + 1)
        starvation.wait_out(board.poll)
    assert QUEUED_SHARE * QUEUED_SPAN_S > 0.003 and starvation.waits == 0


def test_a_process_that_keeps_up_in_late_bursts_is_waited_for_at_each_step_until_it_sleeps():
    # woken by each step's frame (every 4 ms), it gets its CPU 2 ms later, answers and sleeps: half its time queued,
    # though asleep at the end of each burst and never runnable for STARVED_S on end
    board = Process()
    starvation = board.starvation()
    queued_ns = 0
    for step in range(10):
        board.now, board.state = step * 0.004, "R"  # just woken: its last burst's wait is on the books
        board.schedule = (step * 80_000, queued_ns, step)
        board.gets_a_cpu_at = board.now + 0.002
        starvation.wait_out(board.poll)
        if board.state == "R":  # not waited for: it runs and sleeps on its own 2 ms later
            board.state = "S"
        queued_ns += 2_000_000
    assert starvation.waits >= 7  # from the first span of STARVED_S or more on: each step
    assert abs(starvation.waited_s / starvation.waits - 0.002) <= RECHECK_S  # until its burst ends, each time
