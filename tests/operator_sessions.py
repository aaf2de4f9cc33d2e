"""Random operator sessions over the in-memory manager (`memory_fleet`), judged by the truth.

A session runs the lab plan on five virtual robots at the TurtleBot's size, some of
whose bumpers a visitor presses in a random drive, rerouting off or automatic. An
operator presses what a console offers, at random moments: pause, start, step,
halt, disable or enable a robot, switch strategy, replan (and accept or reject the
proposal); meanwhile a robot's link may drop for a while, and the manager may die
and another take the run over from its records. Then the operator cleans up as lab
staff would: enable every robot, answer a proposal, start, and replan while the run
is stuck, a few times. With Vicon (`vicon`), the manager reads a simulated Vicon stream
(`MemoryVicon`), the run starts on either position source, the operator switches the
source at random (every robot or one), and robots are occluded from Vicon for a while. With
`big`, ten to sixteen robots on a random map instead of the lab's five (`big_floor`).

What is checked is what a visitor and the run's report would say against where the
robots really are: the run ends; "done" means every robot is at its goal; the
summary counts as arrived exactly the robots at their goals; the run counted no pair
closer than the safe distance, and no two robots really came closer (their true
poses, every 50 ms of the fleet's clock; a TurtleBot's safe distance when the run
models them as large as a cell). Used by tests/test_manager_operator_sessions.py
(some seeds) and bench/operator_sessions.py (many).
"""
from __future__ import annotations

import math
import random
import re
from collections import Counter
from dataclasses import dataclass, field, replace
from typing import List, Tuple

import numpy as np

from fleet_common.delays import parse_delay_model
from fleet_common.formats.instance import make_instance
from fleet_common.grid import Grid
from fleet_common.plan_loading import LoadedPlan, PlanLoadError, from_instance
from fleet_common.planning.components import component_labels
from fleet_common.robot_size import TURTLEBOT2, cell_sized
from fleet_common.wire import Pose
from fleet_manager.driver import AT_CELL
from fleet_manager.settings import ManagerSettings
from memory_fleet import MemoryFleet, MemoryVicon, lab_fleet
from test_manager_core import lab
from virtual_fleet.delays import FleetDelays

#: what the operator may press; "wait" lets the run go on; "link" drops a robot's link, "restart"
#: kills the manager and starts another on its records
PRESSES = ("pause", "start", "step", "disable", "enable", "replan", "halt", "strategy", "link", "restart",
           "wait", "wait", "wait")
#: and in a wide session: stop, the reroute mode and scope, reset (back to the starts, run again)
WIDE_PRESSES = ("stop", "reroute", "reset")
#: `faults` sessions' delay models (`fleetctl simulate --delay-model`), one drawn a session: the
#: League of Robot Runners' delays, stalls anywhere in a move, slow drives
FAULT_MODELS = ("events=bernoulli:0.1:1-5", "events=bernoulli:0.3:1-5", "stall=0.1:3", "slow=0.2:2,stall=0.05:2",
                "delay=0.3,stall=0.1:2")


def carry_to(f: MemoryFleet, rid: int, x: float, y: float) -> None:
    """Lab staff put robot `rid` down at (x, y), once it stands still (it may be turning in place)."""
    navigator = f.robots[rid].navigator
    f.run_until(lambda: not navigator.moving, 5)
    navigator._rest = Pose(x, y, navigator.true_pose().theta)


def open_cells(grid: Grid) -> List[Tuple[int, int]]:
    """The free cells of the map's largest connected part: lab staff do not put a robot down in a
    pocket walled off from the rest, from where no plan takes it home (the lab's map has none; a
    random map of `big` sessions may: big carrying session 91 put robot 9 in one)."""
    labels = component_labels(grid, np.zeros(grid.free.shape, dtype=bool))
    cells = list(grid.free_cells())
    if not cells:
        return cells
    biggest = Counter(labels[grid.index(c)] for c in cells).most_common(1)[0][0]
    return [c for c in cells if labels[grid.index(c)] == biggest]


def carry_to_a_cell(f: MemoryFleet, rid: int) -> None:
    """Lab staff put robot `rid` (standing still) on the nearest free cell nobody stands on."""
    at = f.robots[rid].navigator.true_pose()
    others = [r.navigator.true_pose() for other, r in f.robots.items() if other != rid]
    cells = [c for c in open_cells(f.core.run.grid)  # (a robot half in a cell stands in it too)
             if all(math.hypot(c[0] - p.x, c[1] - p.y) >= TURTLEBOT2.safe_cells for p in others)]
    x, y = min(cells, key=lambda c: math.hypot(c[0] - at.x, c[1] - at.y))
    carry_to(f, rid, float(x), float(y))


def crowded_lab(rng: random.Random) -> LoadedPlan:
    """Eight robots on the lab's map between random cells, planned by LaCAM (trains of robots
    following each other, as students' plans have them)."""
    grid = lab().grid
    cells = rng.sample(list(grid.free_cells()), 16)
    inst = make_instance(grid, lab().solution.map_file or "lab.map", cells[:8], cells[8:])
    return from_instance(inst, "eight robots on the lab map", solver="lacam", seed=rng.randint(0, 999))


def big_floor(rng: random.Random) -> LoadedPlan:
    """Ten to sixteen robots between random cells of a random map 8-12 cells on a side (up to a
    fifth of it walls, the largest connected part used), planned by LaCAM or PIBT: more robots,
    corridors and dead ends than the lab has, for `big` sessions."""
    for _ in range(20):
        w, h = rng.randint(8, 12), rng.randint(8, 12)
        density = rng.choice([0.0, 0.1, 0.2])
        grid = Grid(np.array([[rng.random() >= density for _ in range(w)] for _ in range(h)]))
        labels = component_labels(grid, np.zeros((h, w), dtype=bool))
        cells = list(grid.free_cells())
        if not cells:
            continue
        biggest = Counter(labels[grid.index(c)] for c in cells).most_common(1)[0][0]
        cells = [c for c in cells if labels[grid.index(c)] == biggest]
        n = min(rng.randint(10, 16), len(cells) // 3)
        if n < 10:
            continue
        inst = make_instance(grid, "random.map", rng.sample(cells, n), rng.sample(cells, n))
        try:
            return from_instance(inst, "{} robots on a random {}x{} map".format(n, w, h),
                                 solver=rng.choice(["lacam", "pibt"]), seed=rng.randint(0, 999))
        except PlanLoadError:  # no plan in time: draw again
            continue
    raise RuntimeError("no random map with a plan in 20 draws")


@dataclass
class Session:
    """What happened (time, action, arguments, accepted, answer) and what was found wrong."""

    seed: int
    log: List[Tuple[float, str, dict, bool, str]] = field(default_factory=list)
    problems: List[str] = field(default_factory=list)


def lost_in(reason: str) -> List[int]:
    """The robots a refusal or the run's line says Vicon does not see (or that never reported a
    pose since the manager started): staff choose their own poses for them, as told."""
    told = re.findall(r"robot (\d+) has not reported a pose", reason)
    lost = re.search(r"Vicon has not seen robots? ([\d, ]+) since", reason)
    return sorted({int(r) for r in told + (lost.group(1).split(", ") if lost else [])})


def session(seed: int, wide: bool = False, dying: bool = False, vicon: bool = False,
            carrying: bool = False, big: bool = False, faults: bool = False) -> Session:
    """One random session (see the module docstring). `wide`: the run varies too, drawn from a
    second generator (the operator's presses stay those of the narrow session's seed): robots as
    large as a cell, the run started under any strategy, rerouting every robot (scope all), and
    poses that reach the manager late, eight robots between random cells of the lab's map in a
    third of them (`crowded_lab`); and the operator also presses stop, reset and the reroute mode.
    `dying` (wide sessions): the operator often stops and resets, and the manager often dies on the
    way back to the starts (draws of its own: the presses stay the seed's). `vicon`: the manager
    reads Vicon's stream (100 or 50 frames a second, 5-30 ms late, a few lost), the run starts on
    either source, and between the presses (and in the clean-up) the operator may switch the source
    and a robot may be occluded, for up to 3 s or now and then for up to 20 s (draws of its own too);
    and no two robots may really come closer than the safe distance (the run's count sees only the
    poses it used). `carrying`: between the presses lab staff now and then pick up a robot standing
    still (most often one that is out) and put it down on a free cell, or between two, well away
    from the others, and sometimes back where it was (draws of their own too); the run's own count
    of pairs too close then does not judge (it reads a robot carried across the floor as one
    driving through the others' cells), the truth does. `big`: ten to sixteen robots on a random
    map instead of the lab's (`big_floor`, draws of its own). `faults`: the robots meet a delay
    model (late starts, slow drives, stalls anywhere in a move: `FAULT_MODELS`), and between the
    presses a robot now and then loses its power alone: it stops where it stands and comes back a
    new process that remembers no command (draws of their own too)."""
    rng = random.Random(seed)
    out = Session(seed)
    reroute = rng.choice(["off", "auto"])
    settings = ManagerSettings(step_time=0.5, size=TURTLEBOT2, reroute=reroute, reroute_timed=False)
    lag = 0.0
    loaded, n = lab(), 5
    if wide:
        run = random.Random(~seed)
        settings = replace(settings, size=run.choice([TURTLEBOT2, TURTLEBOT2, cell_sized()]),
                           strategy=run.choice(["adg", "step", "reorder"]),
                           reroute_scope=run.choice(["held", "all"]))
        lag = run.choice([0.0, 0.1, 0.3])
        if run.random() < 1 / 3:
            loaded, n = crowded_lab(run), 8
    if big:
        loaded = big_floor(random.Random(seed * 7919 + 5))
        n = loaded.agents
    eye = random.Random(seed * 7919 + 2)  # `vicon`: its own draws, the presses stay the seed's
    camera = MemoryVicon(random.Random(seed * 7919 + 3), period=eye.choice([0.01, 0.02]),
                         drops=eye.choice([0.0, 0.02, 0.1])) if vicon else None
    f = MemoryFleet(loaded, lab_fleet(n), settings=settings, pose_lag=lag, vicon=camera)
    for robot in f.robots.values():
        if rng.random() < 0.3:
            robot.navigator.bumps = {rng.randint(1, 4)}
            robot.navigator.bump_seconds = 0.5
    fate = random.Random(seed * 7919 + 6)  # `faults`: its own draws, the presses stay the seed's
    if faults:
        spec = fate.choice(FAULT_MODELS)
        model = parse_delay_model(spec)
        for i, robot in enumerate(f.robots.values()):  # a nominal move: one cell at the fleet's speed
            robot.navigator.model = FleetDelays(model, nominal_s=0.5, seed=seed, num_robots=n, index=i)
            robot.navigator.rng = random.Random(fate.random())
        out.log.append((0.0, "delays", {"model": spec}, True, ""))
    unpowered: set = set()  # `faults`: robots that lost their power, not back yet
    consoles = [f.console()]  # the operator's console; a new one after a restart
    f.link_up()

    def press(action: str, **args: object) -> bool:
        answer = f.ask(consoles[-1], action, **args)
        out.log.append((round(f.now, 1), action, dict(args), answer.ok, answer.reason))
        return answer.ok

    if vicon:  # the run starts on either source, once Vicon's first frames are in
        f.advance(0.1)
        press("source", source=eye.choice(["robot", "vicon"]))
    f.ask(consoles[0], "start")
    down: set = set()
    taken_from: dict = {}  # `carrying`: robot -> where staff picked it up

    def switch_source() -> None:
        """The operator chooses a source: for every robot or for one."""
        press("source", source=eye.choice(["robot", "vicon"]), robot=eye.choice([None, eye.randint(1, n)]))

    def occlude() -> None:
        """Someone stands between the cameras and a robot for a while; now and then Vicon loses
        a robot for longer (a marker knocked off, a robot under a table's edge)."""
        rid, seconds = eye.randint(1, n), eye.uniform(0.05, 3.0) if eye.random() < 0.8 else eye.uniform(3.0, 20.0)
        camera.occlude(rid, f.now + seconds)  # type: ignore[union-attr]
        out.log.append((round(f.now, 1), "occluded", {"robot": rid, "seconds": round(seconds, 2)}, True, ""))

    def own_poses_if_lost(reason: str) -> None:
        """Robots a refusal says Vicon does not see (or never saw since the manager started): staff
        choose their own poses for them, as told."""
        for rid in lost_in(reason):
            press("source", source="robot", robot=rid)

    def links_up() -> None:
        for rid in sorted(down):
            f.link_up(rid)
        down.clear()
        for rid in sorted(unpowered):
            f.link_up(rid, restarted=True)
        unpowered.clear()

    def answer_proposal(choice: str) -> None:
        def cut_off() -> bool:  # the replan waits for a robot whose link is down in a move
            return "or Stop to give the replan up" in f.core.run.phase.reason
        if f.run_until(lambda: f.core.run.replanner.proposal_id is not None or cut_off(), 20) and cut_off() \
                and fate.random() < 0.5:  # (its own draws) staff do what the line offers
            f.advance(fate.uniform(0.0, 3.0))
            if cut_off():
                press("stop")
                return
        if f.run_until(lambda: f.core.run.replanner.proposal_id is not None, 20):
            f.advance(0.1)  # the console sees the State that names the proposal
            if press(choice, proposal=f.core.run.replanner.proposal_id) and choice == "accept":
                taken_from.clear()  # (`carrying`) the run has every robot where it stands now

    def restart(dead: float) -> None:
        links_up()
        f.kill_manager()
        f.advance(dead)
        f.resume_manager()
        consoles.append(f.console())
        f.advance(0.5)
        out.log.append((round(f.now, 1), "restart", {}, True, f.core.run.phase.reason))
        if vicon and eye.random() < 0.5:  # a new manager starts on the robots' own poses
            switch_source()
        if f.core.run.replanner.proposal_id is not None:
            answer_proposal("accept")

    hand = random.Random(seed * 7919 + 4)  # `carrying`: its own draws, the presses stay the seed's

    def clear(rid: int, x: float, y: float) -> bool:
        """No other robot stands within the safe distance of where staff would put robot `rid`."""
        return all(math.hypot(r.navigator.true_pose().x - x, r.navigator.true_pose().y - y) >= TURTLEBOT2.safe_cells
                   for o, r in f.robots.items() if o != rid)

    def pick_up() -> None:
        """Lab staff carry a robot standing still elsewhere, or back to where they took it from,
        while the run is under way; they put it down where they see no robot near, none driving
        towards it (a robot drives up to two cells a second here: 2.5 cells away, it is 1.5 away
        when the run has seen the robot put down and stopped it)."""
        if f.phase not in ("running", "paused", "stopped"):
            return
        still = [rid for rid, r in f.robots.items() if not r.navigator.moving and rid not in down | unpowered]
        # (not one whose link is down: nothing tells the manager where it is until it is back up)
        back = [rid for rid in still if rid in taken_from and clear(rid, *taken_from[rid])]
        if back and hand.random() < 0.3:
            rid = hand.choice(back)
            carry_to(f, rid, *taken_from.pop(rid))
            out.log.append((round(f.now, 1), "carried back", {"robot": rid}, True, ""))
            return
        if not still:
            return
        out_ = [rid for rid in still if f.core.run.engine.run.out[f.core.fleet.by_id[rid].agent] is not None]
        rid = hand.choice(out_ if out_ and hand.random() < 0.7 else still)
        others = [(r.navigator.true_pose(), 2.5 if r.navigator.moving else 1.5)
                  for o, r in f.robots.items() if o != rid]
        cells = [c for c in open_cells(f.core.run.grid)
                 if all(math.hypot(c[0] - p.x, c[1] - p.y) >= away for p, away in others)]
        if not cells:
            return
        x, y = hand.choice(cells)
        grid = f.core.run.grid
        sides = [(dx, dy) for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1))
                 if grid.in_bounds((x + dx, y + dy)) and grid.is_free((x + dx, y + dy))]
        if sides and hand.random() < 0.3:  # put down between two free cells
            dx, dy = hand.choice(sides)
            x, y = x + dx / 2, y + dy / 2
        at = f.robots[rid].navigator.true_pose()
        taken_from.setdefault(rid, (at.x, at.y))
        carry_to(f, rid, float(x), float(y))
        out.log.append((round(f.now, 1), "carried", {"robot": rid, "to": (x, y)}, True, ""))
        f.advance(0.2)  # staff step back (a link dropped the moment it is put down: nothing can see it)

    def put_right(reason: str) -> bool:
        """Robots a refusal says were moved by hand: put on a cell if told so; then replanned from
        where they stand while the run is under way and a replan may be made, else put back where
        the run has them."""
        for rid in map(int, re.findall(r"robot (\d+) stands at [^:;]*not on a free cell's centre", reason)):
            carry_to_a_cell(f, rid)
            out.log.append((round(f.now, 1), "carried", {"robot": rid}, True, ""))
            f.advance(0.6)
            return True  # told again what is left
        moved = [int(r) for r in re.findall(r"robot (\d+) stands at [^;]*?where the run has it", reason)]
        if not moved:
            return False
        if vicon and "Vicon has not seen" in reason:  # moved while Vicon did not see it: as told
            own_poses_if_lost(reason)
            f.advance(0.3)
        if f.phase in ("running", "paused", "stopped") and (press("replan") or (
                "or halt first" in out.log[-1][4] and press("halt") and press("replan"))):  # as told
            answer_proposal("accept")
            return True
        halfway = re.match(r"robots? ([\d, ]+) stopped between two cells after a fault", out.log[-1][4])
        if halfway and not all(clear(rid, *taken_from.get(rid, (math.inf, math.inf))) for rid in moved):
            for rid in map(int, halfway.group(1).split(", ")):  # they cannot finish: Start is refused
                press("disable", robot=rid)
            if press("replan"):
                answer_proposal("accept")
                return True
        held = f.core.run.positions()  # (no replan now: robots between cells must finish first)
        for rid in moved:  # back where it was, as the console says (the run has it on that cell)
            spot = taken_from.pop(rid, tuple(map(float, held[f.core.fleet.by_id[rid].agent])))
            if not clear(rid, *spot):  # somebody was put down there since: on a cell of its own
                carry_to_a_cell(f, rid)
                out.log.append((round(f.now, 1), "carried", {"robot": rid}, True, ""))
                continue
            carry_to(f, rid, *spot)
            out.log.append((round(f.now, 1), "carried back", {"robot": rid}, True, ""))
        f.advance(0.6)  # its next poses come in (up to 0.3 s late in wide sessions)
        return True

    die = random.Random(seed * 7919 + 1)  # `dying`: its own draws, the presses stay the seed's
    for _ in range(rng.randint(3, 12)):
        f.advance(rng.uniform(0.2, 3.0))
        for rid in sorted(down):
            if rng.random() < 0.5:
                f.link_up(rid)
                down.discard(rid)
        for rid in sorted(unpowered):  # back, a new process
            if fate.random() < 0.6:
                f.link_up(rid, restarted=True)
                unpowered.discard(rid)
                out.log.append((round(f.now, 1), "back", {"robot": rid}, True, ""))
        if faults and fate.random() < 0.2:
            rid = fate.randint(1, n)
            if rid not in down | unpowered:
                f.power_cut(rid)
                unpowered.add(rid)
                out.log.append((round(f.now, 1), "power cut", {"robot": rid}, True, ""))
        if vicon and eye.random() < 0.3:
            occlude()
        if vicon and eye.random() < 0.3:
            switch_source()
        if carrying and hand.random() < 0.2:
            pick_up()
        action = rng.choice(PRESSES + WIDE_PRESSES if wide else PRESSES)
        if dying and die.random() < 0.25:  # stop, and reset once the robots stand
            press("stop")
            f.run_until(lambda: not f.core.run.driver.moving, 10)
            f.advance(0.4)  # poses taken standing
            action = "reset"
        if action == "wait":
            continue
        if action == "link":
            rid = rng.randint(1, n)
            if rid not in down | unpowered:
                f.link_down(rid)
                down.add(rid)
                out.log.append((round(f.now, 1), "link down", {"robot": rid}, True, ""))
            continue
        if action == "restart":
            restart(rng.uniform(0.2, 2.0))
            continue
        args: dict = {}
        if action in ("disable", "enable"):
            args["robot"] = rng.randint(1, n)
        elif action == "strategy":
            args["name"] = rng.choice(["adg", "step", "reorder"])
        elif action == "reroute":
            args.update(mode=rng.choice(["off", "propose", "auto"]), scope=rng.choice(["held", "all"]))
        accepted = press(action, **args)
        if accepted and action == "replan":
            answer_proposal(rng.choice(["accept", "accept", "reject"]))
        if accepted and action == "reset" and dying and die.random() < 0.7:  # the manager dies on the way
            f.advance(die.uniform(0.0, 3.0))
            restart(die.uniform(0.2, 2.0))
    links_up()
    for _ in range(8):  # the clean-up (dying seeds 1855, 1962: a bumper stops a robot twice, 6 rounds)
        f.advance(1.0)  # a bumper is free again after 0.5 s
        if vicon and eye.random() < 0.3:  # also while the staff clean up
            occlude()
        for rid in f.robots:
            if f.core.run.engine.run.out[f.core.fleet.by_id[rid].agent] is not None:
                if not press("enable", robot=rid) and "put it on a cell" in out.log[-1][4]:
                    carry_to_a_cell(f, rid)  # as lab staff would, told so
                    out.log.append((round(f.now, 1), "carried", {"robot": rid}, True, ""))
                    f.advance(0.3)  # its next poses come in
                    press("enable", robot=rid)
                if put_right(out.log[-1][4]):  # replanned from where it stands, or put back
                    press("enable", robot=rid)
        if f.core.run.replanner.proposal_id is not None:
            answer_proposal("accept")
        if f.core.run.rerouting.proposal_id is not None:  # a reroute proposed (rerouting on "propose")
            press("accept", proposal=f.core.run.rerouting.proposal_id)
        if not press("start") and "Go to starts drives" in out.log[-1][4]:
            press("to_starts")  # a robot disabled on the way back to the starts stayed off its start
        for _ in range(3):  # as told, until Start goes (--wide --vicon --carrying 1391: put on a cell, then
            if not put_right(out.log[-1][4]) or press("start"):  # the refusal says replan)
                break
        if vicon:
            own_poses_if_lost(out.log[-1][4])
        # (a way back to the starts, after a reset, ends waiting for Start: pressed next round)
        if not f.run_until(lambda: f.phase in ("done", "waiting") or f.core.run.stuck() or
                           f.core.run.replanner.proposal_id is not None, 90):
            break
        if f.core.run.replanner.proposal_id is not None:  # made once a robot back from a power cut
            continue  # finished its move (`faults` 155): answered next round
        if f.phase == "done":  # done with a robot still out (seed 1511 of `--carrying`: a replan made as told
            if all(o is None for o in f.core.run.engine.run.out):  # ended the run before staff enabled it):
                break
            continue  # the next round enables it, a new leg
        if f.phase == "waiting":
            continue
        if press("replan"):
            answer_proposal("accept")
        elif vicon:
            own_poses_if_lost(out.log[-1][4])
        put_right(out.log[-1][4])
    goals = f.core.run.loaded.goals
    home = {rid: math.hypot(r.navigator.true_pose().x - goals[rid - 1][0],
                            r.navigator.true_pose().y - goals[rid - 1][1]) <= AT_CELL
            for rid, r in f.robots.items()}
    summary = f.core.summary()
    if f.phase != "done":
        out.problems.append("not done: {} ({})".format(f.phase, f.core.run.phase.reason or "no reason given"))
    elif not all(home.values()):
        out.problems.append("done, but robots {} are not at their goals".format(
            [rid for rid, at in home.items() if not at]))
    if sorted(summary.arrived) != sorted(rid for rid, at in home.items() if at):
        out.problems.append("the summary counts robots {} arrived; at their goals: {}".format(
            summary.arrived, [rid for rid, at in home.items() if at]))
    if not carrying:  # nobody touched a robot: a robot "moved by hand" is a false alarm
        alarms = [line for line in f.said if re.search(r"away from .{1,40}? where the run has it", line)]
        if alarms:
            out.problems.append("a robot nobody moved was found moved by hand: " + alarms[0])
    if summary.collisions and not carrying:  # (a robot carried across the floor is a drive through
        out.problems.append("{} pairs closer than the safe distance".format(summary.collisions))  # others there)
    # The truth as well as the run's own count, which sees only the poses the manager had (late
    # ones, or none while Vicon lost a robot). The robots are TurtleBots whatever the run's model:
    # robots modelled as large as a cell keep at least a TurtleBot's safe distance too.
    safe = min(settings.size.safe_cells, TURTLEBOT2.safe_cells)
    if f.closest is not None and f.closest[0] < safe - 1e-3:
        out.problems.append("robots {} and {} came {:.2f} cells apart at {:.1f} s (safe: {:.2f})".format(
            f.closest[1], f.closest[2], f.closest[0], f.closest[3], safe))
    return out
