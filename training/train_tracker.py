"""Train the learned tracker: a stable-baselines3 policy (SAC, or PPO) that corrects a
scripted controller. On ImitateVideo-v0 (the default ``--env``, the planar arm) it corrects
the velocity controller (``--control position``: the position controller) behind DON; on
ImitateVideo3D-v0 (``--env ImitateVideo3D-v0``, the SO-101) the position controller
behind the oracle estimator (``--estimator``: any registered one that follows the
scenarios), its residual on the four joints that point the arm (``--residual-joints``).
The estimator's observation drops the frame (``keep_frame=False``).

One env per training scenario, vectorised; clip seeds below 1000 only (``--train-seeds``
for training, ``--val-seeds`` for the periodic evaluation; the evaluation suite's
held-out seeds start at 1000 and are never seen here). Writes TensorBoard logs to
``runs/<run name>/``, and the policy weights and metadata to ``--out`` (default
``runs/<run name>/tracker.pt`` and ``tracker.json``), which `LearnedController` loads.
The shipped policy is replaced only when asked: ``--out imimic_gym/data/checkpoints/tracker.pt``.

``--search KEY=V1,V2 ...`` trains a grid of trials instead (any option below, e.g. seeds
or a learning rate), each a whole run of this script with its own TensorBoard log in
``runs/<run name>/trial_<k>``; the trial with the lowest mean validation RMSE is copied to
``--out``, its metadata listing every trial. ``--backend ray`` runs them as Ray Tune
trials (``--address``: an existing cluster).

    python training/train_tracker.py --out imimic_gym/data/checkpoints/tracker.pt  # shipped
    python training/train_tracker.py --total-timesteps 200          # smoke run, in runs/
    python training/train_tracker.py --search seed=0,1,2 --backend ray  # pick one of three
    python training/train_tracker.py --env ImitateVideo3D-v0 \
        --out imimic_gym/data/checkpoints/tracker3d.pt     # the shipped 3-D tracker
"""

from __future__ import annotations

import argparse
import contextlib
import itertools
import json
import os
import random
import shlex
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import DummyVecEnv
from torch.utils.tensorboard import SummaryWriter
from tqdm import tqdm

import imimic_gym  # noqa: F401  (registers ImitateVideo-v0 and ImitateVideo3D-v0)
from imimic_gym.atomic import atomic_write, write_bytes, write_json
from imimic_gym.checkpoints import file_sha256
from imimic_gym.cli.common import at_least, finite, positive, unit_interval
from imimic_gym.clips.scenarios import get_scenario, scenario_names
from imimic_gym.controllers.learned import FEATURES_VERSION, ResidualTracking
from imimic_gym.estimators.registry import ESTIMATORS
from imimic_gym.evaluation import cannot_score
from imimic_gym.robots.planar import ArmSpec
from imimic_gym.robots.so101 import SO101Spec
from imimic_gym.wrappers import RegistryObservation

ROOT = Path(__file__).resolve().parents[1]

# Per env: the training scenarios, the control mode (the scripted controller under the
# residual), the estimator and the joints the residual acts on (empty: every joint) that an
# option left empty takes. On the SO-101 the reward reads the upper arm's, forearm's and
# hand's directions, which wrist_roll and the gripper do not change: a residual there is
# unrewarded drift (docs/decisions/learned-tracker.md).
ENV_DEFAULTS: dict[str, dict[str, Any]] = {
    "ImitateVideo-v0": {
        "scenarios": ("exp2-servo", "exp3-forearm-none", "exp3-forearm-low",
                      "exp3-forearm-high"),
        "control": "velocity", "estimator": "don", "residual_joints": ()},
    "ImitateVideo3D-v0": {
        "scenarios": ("spatial-reach", "spatial-cup", "spatial-raise", "spatial-curl",
                      "spatial-wave", "spatial"),
        "control": "position", "estimator": "oracle",
        "residual_joints": ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex")},
}


@dataclass
class Args:
    algorithm: str = "sac"
    """the SB3 algorithm: sac or ppo"""
    env: str = "ImitateVideo-v0"
    """the env the tracker drives: ImitateVideo-v0 (the planar arm) or ImitateVideo3D-v0
    (the SO-101 copying an arm in space; its scenarios are the spatial ones)"""
    scenarios: tuple[str, ...] = ()
    """training scenarios, one vectorised env each, all with the same number of moving
    links; default: exp2-servo exp3-forearm-none exp3-forearm-low exp3-forearm-high on
    ImitateVideo-v0 (one link: DON follows one link), spatial-reach spatial-cup
    spatial-raise spatial-curl spatial-wave spatial on ImitateVideo3D-v0"""
    estimator: str = ""
    """the registered estimator whose obs['estimate'] the policy reads; default: don on
    ImitateVideo-v0, oracle (the retargeted truth) on ImitateVideo3D-v0"""
    train_seeds: int = 48
    """training clips per scenario: clip seeds 0 .. train_seeds-1"""
    val_seeds: tuple[int, ...] = (900, 901)
    """clip seeds for the periodic evaluation (below 1000 and not trained on)"""
    total_timesteps: int = 160_000
    """env steps over all envs (one step = one video frame)"""
    eval_every: int = 20_000
    """env steps between periodic evaluations"""
    frames: int | None = None
    """clip length in frames, short for smoke runs; default: the scenario's (150 frames,
    5 s)"""
    control: str = ""
    """the robot's actuation, and so the scripted controller under the residual:
    position or velocity; default: velocity on ImitateVideo-v0, position on
    ImitateVideo3D-v0 (the SO-101's servos take target angles only)"""
    residual_scale: float = 1.0
    """the policy's action, times this, is added to the scripted controller's (both
    normalised to [-1, 1] of the actuator's range)"""
    residual_joints: tuple[str, ...] = ()
    """the joints the residual acts on, by name (the others follow the scripted controller
    exactly); default: every joint on ImitateVideo-v0, shoulder_pan shoulder_lift
    elbow_flex wrist_flex on ImitateVideo3D-v0"""
    reward_balance: float = 1.0
    """each scenario's reward is divided by the scripted controller's mean squared error
    there (rad^2) to this power: 1 weighs scenarios by relative improvement, 0 by raw
    error"""
    history: int = 6
    """extra frames of estimate history in the policy's features (TrackerFeatures)"""
    rate_history: int = 12
    """frames of past estimated omega and trust in the policy's features (TrackerFeatures)"""
    net_arch: tuple[int, ...] = (128, 128)
    """hidden layers of the actor and the critics, units each"""
    learning_rate: float = 1e-3
    """Adam learning rate (constant)"""
    gamma: float = 0.9
    """discount per env step (frame): tracking is short-sighted, ten frames of horizon are
    enough to anticipate"""
    batch_size: int = 256
    """transitions per gradient update (SAC's and PPO's minibatch)"""
    gradient_steps: int = 2
    """SAC: gradient updates per vectorised env step (one step of every env)"""
    learning_starts: int = 2_000
    """SAC: env steps with uniformly random residuals (exploration) before the first update"""
    seed: int = 0
    """seeds torch, numpy, random and the envs (0, with reward balance 1: the shipped
    policy's; benchmarks/RESULTS.md lists the candidates it was chosen from)"""
    threads: int = 1
    """torch CPU threads (the machine is shared; 1 is as fast for these small nets)"""
    out: str = ""
    """where to write the policy weights (the metadata goes to the same name .json);
    default: logdir/<run name>/tracker.pt. The shipped one is
    imimic_gym/data/checkpoints/tracker.pt"""
    logdir: str = "runs"
    """TensorBoard log folder, in the working directory unless absolute; the run writes
    into logdir/<run name>"""
    run_name: str = field(default="")
    """the run's name, its folder in logdir; default:
    tracker__<algorithm>__<seed>__<unix time>"""
    search: tuple[str, ...] = ()
    """a grid of trials instead of one run: KEY=V1,V2 ... over the options above (e.g.
    seed=0,1 learning_rate=1e-3,3e-4); the one with the lowest mean validation RMSE
    (learned, over the scenarios) goes to --out; default: none, one run"""
    backend: str = "local"
    """--search: trials one after another here (local) or as Ray Tune trials (ray)"""
    address: str = ""
    """--backend ray: a Ray cluster ('auto', 'ray://host:10001'); default: the Ray that
    `ray start` runs on this machine, else a new local one"""


# What argparse checks of an option beyond its default's type: a value that cannot work is
# refused in one line before any work.
CHECKS: dict[str, dict[str, Any]] = {
    "algorithm": {"choices": ("sac", "ppo")},
    "env": {"choices": tuple(ENV_DEFAULTS)},
    "estimator": {"choices": tuple(ESTIMATORS)},
    "scenarios": {"choices": scenario_names(), "metavar": "SCENARIO"},
    "train_seeds": {"type": at_least(1)},
    "val_seeds": {"type": at_least(0)},
    "eval_every": {"type": at_least(1)},
    "frames": {"type": at_least(2)},
    "control": {"choices": ("position", "velocity")},
    "residual_scale": {"type": positive},
    "reward_balance": {"type": finite},
    "history": {"type": at_least(0)},
    "rate_history": {"type": at_least(0)},
    "net_arch": {"type": at_least(1)},
    "learning_rate": {"type": positive},
    "gamma": {"type": unit_interval},
    "batch_size": {"type": at_least(1)},
    "gradient_steps": {"type": at_least(1)},
    "learning_starts": {"type": at_least(0)},
    "seed": {"type": at_least(0)},
    "threads": {"type": at_least(1)},
    "backend": {"choices": ("local", "ray")},
}


def parse_args(argv: list[str] | None = None) -> Args:
    """The options of ``argv`` (default: this command line), checked: exits 2 with one line
    on a mistake, before any work."""
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    docs = _field_docs()
    for f in fields(Args):
        default = getattr(Args, f.name, None) if f.name != "run_name" else ""
        flag, doc = "--" + f.name.replace("_", "-"), docs[f.name]
        shown = " ".join(map(str, default)) if isinstance(default, tuple) else default
        help_text = doc if "default:" in doc else f"{doc} (default: {shown})"
        if isinstance(default, bool):
            parser.add_argument(flag, action=argparse.BooleanOptionalAction, default=default,
                                help=help_text)
        elif isinstance(default, tuple):
            kind = type(default[0]) if default else str
            parser.add_argument(flag, nargs="+", default=default, help=help_text,
                                **{"type": kind, **CHECKS.get(f.name, {})})
        else:
            parser.add_argument(flag, default=default, help=help_text,
                                **{"type": type(default), **CHECKS.get(f.name, {})})
    ns = parser.parse_args(argv)
    args = Args(**{k: tuple(v) if isinstance(v, list) else v for k, v in vars(ns).items()})
    if args.total_timesteps < 1:
        parser.error(f"--total-timesteps must be at least 1, got {args.total_timesteps}: an "
                     "untrained policy is no policy; nothing written")
    for name, default in ENV_DEFAULTS[args.env].items():
        if not getattr(args, name):
            setattr(args, name, default)
    spatial = args.env == "ImitateVideo3D-v0"
    wrong = [name for name in args.scenarios if get_scenario(name).spatial != spatial]
    if wrong:
        parser.error("--scenarios: " + (
            f"planar scenarios on ImitateVideo3D-v0, which takes spatial ones: {wrong}"
            if spatial else f"spatial scenarios on ImitateVideo-v0: {wrong}; train them "
                            "with --env ImitateVideo3D-v0"))
    if spatial and args.control != "position":
        parser.error(f"--control: the SO-101's servos take target angles: ImitateVideo3D-v0 "
                     f"takes position, got {args.control}")
    for name in args.scenarios:
        why = cannot_score(name, args.estimator, controlled=True)
        if why:
            parser.error(f"--estimator: {why}")
    links = {name: get_scenario(name).n_links for name in args.scenarios}
    if len(set(links.values())) > 1:
        parser.error("--scenarios: one policy drives one arm, but " + ", ".join(
            f"{name} has {n}" for name, n in links.items()) + " moving links")
    names = robot_joint_names(args.env, next(iter(links.values())))
    unknown = [name for name in args.residual_joints if name not in names]
    if unknown or len(set(args.residual_joints)) != len(args.residual_joints):
        parser.error(f"--residual-joints: distinct joints of the {args.env} arm {names}, got "
                     f"{list(args.residual_joints)}")
    if any(s >= 1000 for s in args.val_seeds) or args.train_seeds > min(args.val_seeds):
        parser.error("training and validation clip seeds must stay below 1000 (held out) and "
                     "the training seeds below the validation ones")
    return args


def robot_joint_names(env: str, n_links: int) -> tuple[str, ...]:
    """The joint names of the arm ``env`` builds for scenarios with ``n_links`` moving
    links, in its action's order (the SO-101's; the planar arm's q1, q2, ...)."""
    if env == "ImitateVideo3D-v0":
        return SO101Spec().joint_names
    return ArmSpec(link_lengths=(1.0,) * n_links, link_masses=(1.0,) * n_links,
                   joint_ranges=((-1.0, 1.0),) * n_links).joint_names


def _field_docs() -> dict[str, str]:
    """Each Args field's docstring (the string literal under it), for --help."""
    import ast
    import inspect

    tree = ast.parse(inspect.getsource(Args))
    body = tree.body[0].body
    docs = {}
    for node, after in itertools.pairwise(body):
        if isinstance(node, ast.AnnAssign) and isinstance(after, ast.Expr):
            docs[node.target.id] = str(after.value.value).replace("%", "%%")
    return docs


def make_env(scenario: str, seeds: tuple[int, ...], args: Args,
             reward_scale: float = 1.0) -> gym.Env:
    """``args.env`` (``args.control``) -> ``args.estimator`` (no frame) -> residual
    features/actions."""
    kwargs = {"n_frames": args.frames} if args.frames else {}
    env = gym.make(args.env, scenario=scenario, control=args.control, clip_seeds=seeds,
                   **kwargs)
    return ResidualTracking(RegistryObservation(env, args.estimator, keep_frame=False),
                            args.residual_scale, reward_scale, args.history,
                            args.rate_history, args.residual_joints or None)


def reward_scales(args: Args, seeds: tuple[int, ...]) -> dict[str, float]:
    """Per scenario, (the mean squared error (rad^2) of the scripted controller alone, a
    zero residual, on the first two training clips) ** -reward_balance. With balance 1
    every scenario's reward counts relative to what the scripted controller already
    achieves there; with 0 the occluded forearm's errors (tens of degrees) drown the
    servo's (a degree or two) in the critic's targets."""
    scales = {}
    for scenario in args.scenarios:
        env = make_env(scenario, seeds, args)
        squared = []
        for seed in seeds[:2]:
            env.reset(seed=seed, options={"clip_seed": seed})
            done = False
            while not done:
                _, reward, terminated, truncated, _ = env.step(np.zeros(env.action_space.shape))
                squared.append(-reward)
                done = terminated or truncated
        scales[scenario] = max(float(np.mean(squared)), 1e-6) ** -args.reward_balance
        env.close()
    return scales


def episode_rmse_deg(env: gym.Env, act, seeds: tuple[int, ...]) -> float:
    """Mean over ``seeds`` of one episode's RMS tracking error (deg), acting with ``act``."""
    errors = []
    for seed in seeds:
        obs, info = env.reset(seed=seed, options={"clip_seed": seed})
        squared, done = [], False
        while not done:
            obs, _, terminated, truncated, info = env.step(act(obs))
            squared.append(info["tracking_error_deg"] ** 2)
            done = terminated or truncated
        errors.append(float(np.sqrt(np.mean(squared))))
    return float(np.mean(errors))


def evaluate(policy, args: Args) -> dict[str, float]:
    """Deterministic policy vs the untrained residual (the scripted controller) on the
    validation seeds: RMSE (deg) per scenario, mean over seeds."""
    result = {}
    for scenario in args.scenarios:
        env = make_env(scenario, args.val_seeds, args)
        untrained = np.zeros(env.action_space.shape, dtype=np.float32)
        result[f"{scenario}/learned_rmse_deg"] = episode_rmse_deg(
            env, lambda o: policy.predict(o, deterministic=True)[0], args.val_seeds)
        result[f"{scenario}/scripted_rmse_deg"] = episode_rmse_deg(
            env, lambda o, a=untrained: a, args.val_seeds)
        env.close()
    return result


class Progress(BaseCallback):
    """tqdm bar, episode charts, and the periodic evaluation, logged to TensorBoard."""

    def __init__(self, args: Args, writer: SummaryWriter) -> None:
        super().__init__()
        self.args, self.writer, self.next_eval = args, writer, args.eval_every
        self.bar = tqdm(total=args.total_timesteps, desc="train_tracker", unit="step")
        self.start = time.time()
        self.last_eval: dict[str, float] = {}

    def _on_step(self) -> bool:
        self.bar.update(self.training_env.num_envs)
        step = self.num_timesteps
        for info in self.locals.get("infos", []):
            if "episode" in info:
                self.writer.add_scalar("charts/episodic_return", info["episode"]["r"], step)
        if step >= self.next_eval:
            self.next_eval += self.args.eval_every
            self._evaluate(step)
        return True

    def _evaluate(self, step: int) -> None:
        self.last_eval = evaluate(self.model, self.args)
        for key, value in self.last_eval.items():
            self.writer.add_scalar(f"eval/{key}", value, step)
        self.writer.add_scalar("charts/SPS", step / (time.time() - self.start), step)
        self.bar.write(f"step {step}: " + ", ".join(f"{k} {v:.2f}"
                                                    for k, v in self.last_eval.items()))


def main() -> None:
    args = parse_args()
    if args.search:
        search(args)
        return
    args.run_name = args.run_name or f"tracker__{args.algorithm}__{args.seed}__{int(time.time())}"
    args.out = args.out or os.path.join(args.logdir, args.run_name, "tracker.pt")
    # The folders this run makes, deepest first: a failed run leaves none of them empty.
    made = sorted({folder for path in (Path(args.logdir, args.run_name), Path(args.out).parent)
                   for folder in (path, *path.parents) if not folder.exists()},
                  key=lambda folder: len(folder.parts), reverse=True)
    try:
        train(args)
    except BaseException:
        for folder in made:
            with contextlib.suppress(OSError):  # not empty: the logs of a run that trained
                folder.rmdir()
        raise


def train(args: Args) -> None:
    """One run of ``args`` (with its run name and --out set): the policy to --out, its
    metadata beside it, TensorBoard logs to logdir/<run name> once training starts."""
    try:  # before training, not after it: an --out that cannot be written is said now
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=Path(args.out).parent):
            pass
    except OSError as error:
        print(f"train_tracker.py: cannot write --out {args.out}: {error}", file=sys.stderr)
        sys.exit(2)

    # Seeding: identical arguments give an identical run.
    random.seed(args.seed)
    np.random.seed(args.seed)
    torch.manual_seed(args.seed)
    torch.set_num_threads(args.threads)

    train_seeds = tuple(range(args.train_seeds))
    from stable_baselines3.common.monitor import Monitor

    scales = reward_scales(args, train_seeds)
    venv = DummyVecEnv([lambda s=s: Monitor(make_env(s, train_seeds, args, scales[s]))
                        for s in args.scenarios])
    venv.seed(args.seed)
    policy_kwargs = {"net_arch": list(args.net_arch)}
    if args.algorithm == "sac":
        from stable_baselines3 import SAC

        model = SAC("MlpPolicy", venv, learning_rate=args.learning_rate, gamma=args.gamma,
                    batch_size=args.batch_size, learning_starts=args.learning_starts,
                    gradient_steps=args.gradient_steps,
                    policy_kwargs=policy_kwargs, seed=args.seed, device="cpu", verbose=0)
    else:
        from stable_baselines3 import PPO

        model = PPO("MlpPolicy", venv, learning_rate=args.learning_rate, gamma=args.gamma,
                    batch_size=args.batch_size, n_steps=512, policy_kwargs=policy_kwargs,
                    seed=args.seed, device="cpu", verbose=0)
    writer = SummaryWriter(os.path.join(args.logdir, args.run_name))
    writer.add_text("hyperparameters", "|param|value|\n|-|-|\n" + "\n".join(
        f"|{k}|{v}|" for k, v in asdict(args).items()))
    model.set_logger(_sb3_logger(writer.log_dir))
    callback = Progress(args, writer)
    start = time.time()
    model.learn(total_timesteps=args.total_timesteps, callback=callback)
    callback.bar.close()
    train_s = time.time() - start
    final = evaluate(model, args)
    for key, value in final.items():
        writer.add_scalar(f"eval/{key}", value, model.num_timesteps)
    writer.close()

    out = Path(args.out)
    with atomic_write(out) as stream:
        torch.save(model.policy.state_dict(), stream)
    import stable_baselines3

    metadata = {
        "algorithm": args.algorithm,
        "features_version": FEATURES_VERSION,
        "observation_size": int(venv.observation_space.shape[0]),
        "action_size": int(venv.action_space.shape[0]),
        "net_arch": list(args.net_arch),
        "residual_scale": args.residual_scale,
        "residual_joints": list(args.residual_joints or robot_joint_names(
            args.env, get_scenario(args.scenarios[0]).n_links)),
        "reward_scales": scales,
        "history_frames": args.history,
        "rate_history_frames": args.rate_history,
        "env": args.env,
        "control": args.control,
        "estimator": args.estimator,
        "scenarios": list(args.scenarios),
        "train_seeds": list(train_seeds),
        "val_seeds": list(args.val_seeds),
        "total_timesteps": int(model.num_timesteps),
        "train_seconds": round(train_s, 1),
        "torch_threads": args.threads,
        "stable_baselines3": stable_baselines3.__version__,
        "sha256": file_sha256(out),
        "torch": torch.__version__,
        "run_name": args.run_name,
        "command": shlex.join(["python", "training/train_tracker.py", *sys.argv[1:]]),
        "val_metrics": final,
        "args": {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(args).items()},
    }
    write_json(out.with_suffix(".json"), metadata)
    print(f"wrote {out} and {out.with_suffix('.json')} after {train_s:.0f} s")
    for key, value in final.items():
        print(f"  {key:40s} {value:6.2f}")


# Options a trial takes from the search, not from the grid.
SEARCH_OWN = ("search", "backend", "address", "out", "logdir", "run_name")


def search_grid(args: Args) -> list[dict[str, object]]:
    """The trials of ``--search KEY=V1,V2 ...``: every combination, each a dict of the
    options it changes, values parsed as the option's type. Exits 2 on a malformed entry."""
    kinds = {f.name: getattr(Args, f.name) for f in fields(Args) if f.name not in SEARCH_OWN}
    axes = []
    for entry in args.search:
        key, _, values = entry.partition("=")
        key = key.strip().replace("-", "_")
        if key not in kinds or not values:
            print(f"train_tracker.py: --search {entry!r}: expected KEY=V1,V2 with KEY one of "
                  f"{', '.join(sorted(kinds))}", file=sys.stderr)
            sys.exit(2)
        default = kinds[key]
        # A tuple option (scenarios, val_seeds, net_arch) takes one value a trial.
        kind = (type(default[0]) if default else str) if isinstance(default, tuple) else (
            type(default) if default is not None else int)
        try:
            axes.append([(key, (kind(v),) if isinstance(default, tuple) else kind(v))
                         for v in values.split(",")])
        except ValueError:
            print(f"train_tracker.py: --search {entry!r}: values must be {kind.__name__}",
                  file=sys.stderr)
            sys.exit(2)
    return [dict(combo) for combo in itertools.product(*axes)]


def trial_argv(args: Args, overrides: dict[str, object], folder: Path) -> list[str]:
    """This script's command line for one trial: ``args`` with ``overrides``, writing its
    policy to ``folder/tracker.pt`` and its TensorBoard log to ``folder``."""
    argv = []
    for f in fields(Args):
        value = overrides.get(f.name, getattr(args, f.name))
        if f.name in SEARCH_OWN or value is None or value == ():  # (): the default
            continue
        flag = "--" + f.name.replace("_", "-")
        argv += [flag, *map(str, value)] if isinstance(value, tuple) else [flag, str(value)]
    return [*argv, "--out", str(folder / "tracker.pt"), "--logdir", str(folder.parent),
            "--run-name", folder.name]


def run_trial(argv: list[str]) -> float:
    """Train one trial (this script, in a process of its own) and return its validation
    score: the learned policy's RMSE (deg), mean over the scenarios."""
    subprocess.run([sys.executable, str(Path(__file__).resolve()), *argv], check=True)
    out = Path(argv[argv.index("--out") + 1])
    metrics = json.loads(out.with_suffix(".json").read_text())["val_metrics"]
    return float(np.mean([v for k, v in metrics.items() if k.endswith("/learned_rmse_deg")]))


def _tune_trial(config: dict, argvs: list[list[str]]) -> None:
    from ray import tune

    tune.report({"val_rmse_deg": run_trial(argvs[config["trial"]])})


def search(args: Args) -> None:
    """Train every trial of the grid, here or as Ray Tune trials, and copy the one with
    the lowest validation score (validation clips only) to ``--out``."""
    grid = search_grid(args)
    args.run_name = args.run_name or f"tracker_search__{int(time.time())}"
    run_dir = (Path(args.logdir) / args.run_name).resolve()
    out = Path(args.out or run_dir / "tracker.pt")
    argvs = [trial_argv(args, overrides, run_dir / f"trial_{k}")
             for k, overrides in enumerate(grid)]
    for argv in argvs:  # checked as each trial's run will check them, before the first
        parse_args(argv)
    scores: dict[int, float] = {}
    if args.backend == "local":
        for k, argv in enumerate(tqdm(argvs, desc="trials", unit="trial")):
            try:
                scores[k] = run_trial(argv)
            except subprocess.CalledProcessError as error:
                print(f"trial_{k} {grid[k]} failed: {error}", file=sys.stderr)
    else:
        scores = _search_on_ray(args, argvs, run_dir)
    for k in range(len(grid)):
        if k not in scores:
            print(f"trial_{k} {grid[k]}: failed (its output above says why)", file=sys.stderr)
    if not scores:
        print("train_tracker.py: every trial failed; nothing written", file=sys.stderr)
        sys.exit(1)
    best = min(scores, key=lambda k: scores[k])
    chosen = run_dir / f"trial_{best}" / "tracker.pt"
    if out.resolve() != chosen.resolve():
        write_bytes(out, chosen.read_bytes())
    metadata = json.loads(chosen.with_suffix(".json").read_text())
    metadata["search"] = {
        "grid": list(args.search), "backend": args.backend, "chosen": f"trial_{best}",
        "rule": "lowest validation RMSE of the learned policy, mean over the scenarios",
        "trials": [{"trial": f"trial_{k}", "options": grid[k], "val_rmse_deg": scores.get(k)}
                   for k in range(len(grid))]}
    metadata["command"] = shlex.join(["python", "training/train_tracker.py", *sys.argv[1:]])
    write_json(out.with_suffix(".json"), metadata)
    print(f"wrote {out} (trial_{best}, {grid[best]}: validation RMSE {scores[best]:.2f} deg) "
          f"and {out.with_suffix('.json')}")
    for k in sorted(scores, key=lambda k: scores[k]):
        print(f"  trial_{k:<3d} {scores[k]:7.2f} deg  {grid[k]}")


def _search_on_ray(args: Args, argvs: list[list[str]], run_dir: Path) -> dict[int, float]:
    """The trials as Ray Tune trials (one CPU each); their scores by trial index."""
    from imimic_gym.backends import BackendError, ray_session

    try:
        with ray_session(args.address or None):  # says what to install if Ray is missing
            try:
                from ray import tune
            except ImportError as error:
                raise BackendError(f"--search on Ray needs Ray Tune ({error}): pip install "
                                   "'ray[tune]'") from error
            tuner = tune.Tuner(
                tune.with_resources(tune.with_parameters(_tune_trial, argvs=argvs),
                                    {"cpu": 1}),
                param_space={"trial": tune.grid_search(list(range(len(argvs))))},
                tune_config=tune.TuneConfig(metric="val_rmse_deg", mode="min"),
                run_config=tune.RunConfig(name="tune", storage_path=str(run_dir), verbose=1))
            results = tuner.fit()
    except BackendError as error:
        print(f"train_tracker.py: {error}", file=sys.stderr)
        sys.exit(2)
    return {r.config["trial"]: float(r.metrics["val_rmse_deg"]) for r in results
            if r.error is None and r.metrics and "val_rmse_deg" in r.metrics}


def _sb3_logger(folder: str):
    """SB3's own losses (``train/...``) into the same TensorBoard run."""
    from stable_baselines3.common.logger import configure

    return configure(folder, ["tensorboard"])


if __name__ == "__main__":
    main()
