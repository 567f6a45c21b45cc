"""Bad input, second pass: a catalogue of damaged run files and manifests, malformed arrays, a user's faulty
environment, sloppy numbers, lists and arguments, and refused resumes, each given as a careless or hostile user (or a
damaged disk) would give it, most of them generated family by family.

Each case is classified: ``clean`` when a refusal is one line (exit 1, no traceback) that says what is wrong, with
the store byte for byte as it was (every file's hash, every folder), or when a legitimate input does what is
documented; otherwise ``traceback``, ``accepted``, ``store changed``, ``several lines``, ``unclear: ...`` or
``hang`` (nothing may wait forever: a FIFO planted where a file is expected). Every case must be clean; a failure
names its class, so ``pytest -rf`` on an older lwail counts what each family got before."""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import gymnasium as gym
import numpy as np
import pytest
import torch

from conftest import write_states_npz
from lwail_cli import config as cfg
from lwail_cli.artifacts import Store
from lwail_cli.errors import LwailError
from lwail_cli.manifests import content_hash, manifest_hash
from lwail_cli.stages import collect, demos, embed, expert, imitate, warmup

ENV = "InvertedPendulum-v5"
HANG_SECONDS = 60  # a hang never returns; a legitimate 40-step imitate takes ~10 s on a core shared with two runs
CPU = torch.device("cpu")

# the killed runs of the three long stages, and the flags that resume each exactly (so a refusal is the input's doing)
ONLINE_FLAGS = ("--steps", "40", "--eval-every", "20", "--checkpoint-every", "20", "--set", "td3.hidden=8", "--set", "train.eval_episodes=1")
RESUMES = {
    "expert-train": ("policy", "killed-expert", ("expert", "train", ENV, *ONLINE_FLAGS)),
    "imitate": ("policy", "killed-imitate", ("imitate", ENV, "--demos", "ip", "--embedding", "ident", "--disc", "disc", *ONLINE_FLAGS)),
    "pretrain-icvf": ("embedding", "killed-icvf", ("pretrain-icvf", "data", "--steps", "6", "--batch-size", "16", "--embedding-dim", "8",
                                                   "--set", "icvf.hidden=8", "--set", "icvf.checkpoint_every=2", "--set", "icvf.log_every=2")),
}


class Killed(Exception):
    pass


class Hang(Exception):
    pass


def _kill_at(last: int):
    def report(step, shown):
        if step >= last:  # the run's last step: its earlier checkpoint survives, as after a kill
            raise Killed
    return report


@pytest.fixture(scope="module")
def template(tmp_path_factory):
    """One store with what the cases need: two of each kind (demos ip/ip2, datasets data/data2, identity embeddings
    ident/ident2, discriminators disc/disc2, tiny policies p/p2), and a killed run of each long stage (resumable
    with RESUMES' flags, seed 0)."""
    root = tmp_path_factory.mktemp("template")
    store = Store(root / "store")
    for name, seed in (("ip", 0), ("ip2", 1)):
        write_states_npz(root / f"{name}.npz", episodes=2, obs_dim=4, seed=seed, returns=[10.0, 12.0])
        demos.import_demos(store, env_id=ENV, name=name, npz=root / f"{name}.npz")
    for name, seed in (("data", 0), ("data2", 1)):
        write_states_npz(root / f"{name}.npz", episodes=4, obs_dim=4, seed=seed)
        collect.import_dataset(store, env_id=ENV, name=name, npz=root / f"{name}.npz")
    for suffix in ("", "2"):
        embed.embed(store, data_ref="data", config=cfg.EmbedConfig(kind="identity"), seed=0, name=f"ident{suffix}", device=CPU)
        warmup.warmup(store, embedding_ref="ident", demos_ref="ip", config=cfg.WarmupConfig(steps=2), seed=0, name=f"disc{suffix}", device=CPU)
    online = ["td3.hidden=8", "train.eval_episodes=1"]
    schedule = cfg.TrainConfig(steps=40, eval_every=20, checkpoint_every=20)
    expert_config = cfg.with_overrides(cfg.ExpertConfig(train=schedule), online)
    for name in ("p", "p2"):
        expert.train_expert(store, env_id=ENV, config=expert_config, seed=0, name=name, device=CPU)
    with pytest.raises(Killed):
        expert.train_expert(store, env_id=ENV, config=expert_config, seed=0, name="killed-expert", device=CPU, on_progress=_kill_at(40))
    with pytest.raises(Killed):
        imitate.imitate(store, env_id=ENV, demos_ref="ip", embedding_ref="ident", disc_ref="disc", seed=0, name="killed-imitate", device=CPU,
                        config=cfg.with_overrides(cfg.ImitationConfig(train=schedule, expert_episodes=1), online), on_progress=_kill_at(40))
    icvf = cfg.ICVFConfig(steps=6, batch_size=16, embedding_dim=8)
    with pytest.raises(Killed):
        embed.embed(store, data_ref="data", seed=0, name="killed-icvf", device=CPU, on_progress=_kill_at(4),
                    config=cfg.with_overrides(cfg.EmbedConfig(kind="icvf", icvf=icvf), ["icvf.hidden=8", "icvf.checkpoint_every=2", "icvf.log_every=2"]))
    return store.root


@pytest.fixture
def ctx(template, store, cli, tmp_path):
    shutil.copytree(template, store.root, symlinks=True)
    return Context(store, cli, tmp_path)


@dataclass
class Context:
    store: Store
    cli: Callable
    tmp: Path

    def run_folder(self, stage: str) -> Path:
        kind, name, _ = RESUMES[stage]
        return self.store.root / ".runs" / kind / name


@dataclass(frozen=True)
class Case:
    family: str
    label: str
    run: Callable[[Context], str]  # the case's class: "clean" or what went wrong

    @property
    def id(self) -> str:
        return f"{self.family}: {self.label}"


def snapshot(root: Path) -> dict[str, str]:
    """Every file's hash and every other entry's type under the store (links and FIFOs are never opened)."""
    if not root.exists():
        return {}
    entries = {}
    for path in sorted(root.rglob("*")):
        if path.is_symlink() or not (path.is_file() or path.is_dir()):
            entries[str(path.relative_to(root))] = "link" if path.is_symlink() else "special"
        else:
            entries[str(path.relative_to(root))] = hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else "folder"
    return entries


def _on_alarm(signum, frame):
    raise Hang


@contextlib.contextmanager
def _deadline():
    """Raise Hang in whatever runs for more than HANG_SECONDS (a blocking open of a FIFO included)."""
    previous = signal.signal(signal.SIGALRM, _on_alarm)
    signal.alarm(HANG_SECONDS)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def refused(args_of: Callable[[Context], tuple], message: str, exit_code: int = 1) -> Callable[[Context], str]:
    """A refusal: exit code 1 (2 for a typer range check), one line holding ``message``, the store untouched."""
    def run(ctx: Context) -> str:
        args = args_of(ctx)
        before = snapshot(ctx.store.root)
        with _deadline():
            result = ctx.cli(*args)  # the runner keeps what the command raised, Hang included
        if isinstance(result.exception, Hang):
            return "hang"
        if "Traceback" in result.output or not isinstance(result.exception, (SystemExit, type(None))):
            return f"traceback ({type(result.exception).__name__})"
        if result.exit_code == 0:
            return "accepted"
        if snapshot(ctx.store.root) != before:
            return "store changed"
        lines = [line for line in result.output.strip().splitlines() if not re.search(r"\d+%\|", line)]  # a progress bar's last state
        if exit_code == 1 and len(lines) != 1:
            return "several lines"
        if result.exit_code != exit_code or message not in result.output:
            return f"unclear: exit {result.exit_code}, {lines[-1] if lines else ''}"
        return "clean"
    return run


def guarded(check: Callable[[Context], bool]) -> Callable[[Context], str]:
    """A legitimate input (or one with a documented meaning): ``check`` says whether it did what is documented."""
    def run(ctx: Context) -> str:
        try:
            with _deadline():
                return "clean" if check(ctx) else "not as documented"
        except Hang:
            return "hang"
        except LwailError as exc:
            return f"refused: {exc}"
        except Exception as exc:
            return f"traceback ({type(exc).__name__})"
    return run


def _dead_pid() -> int:
    with subprocess.Popen(["true"]) as gone:
        pass
    return gone.pid


def _fifo(path: Path) -> None:
    path.unlink(missing_ok=True)
    os.mkfifo(path)


# ------------------------------------------------------------------------------ damaged run files
def _torch_bytes(value) -> bytes:
    buffer = io.BytesIO()
    torch.save(value, buffer)
    return buffer.getvalue()


DAMAGED_LOCKS = {
    "binary": lambda p: p.write_bytes(b"\xff\xfe\x00\x01garbage"),
    "empty": lambda p: p.write_bytes(b""),
    "no pid": lambda p: p.write_text(socket.gethostname()),
    "pid zero": lambda p: p.write_text(f"{socket.gethostname()} 0"),
    "10 MB of text": lambda p: p.write_bytes(b"x" * 10_000_000),
    "a folder": lambda p: p.mkdir(),
    "a FIFO": _fifo,
    "a link to a FIFO": lambda p: (_fifo(p.with_name("elsewhere")), p.symlink_to(p.with_name("elsewhere"))),
}
DAMAGED_CHECKPOINTS = {
    "empty": lambda p: p.write_bytes(b""),
    "random bytes": lambda p: p.write_bytes(np.random.default_rng(0).bytes(300)),
    "text": lambda p: p.write_text("hello world\n"),
    "cut short": lambda p: p.write_bytes(_torch_bytes({"record": {}, "weights": torch.zeros(4000)})[:-400]),
    "a zip of something else": lambda p: p.write_bytes(_zip_bytes({"notes.txt": b"not a checkpoint"})),
    "a list": lambda p: p.write_bytes(_torch_bytes([1, 2, 3])),
    "a dict without its record": lambda p: p.write_bytes(_torch_bytes({"step": 1})),
    "a folder": lambda p: p.mkdir(),
}


def _damaged_run_file(stage: str, filename: str, make) -> Callable[[Context], str]:
    kind, name, args = RESUMES[stage]

    def args_of(ctx: Context) -> tuple:
        path = ctx.run_folder(stage) / filename  # the killed run's checkpoint, or its lock (none: the run was killed)
        path.unlink(missing_ok=True)
        make(path)
        return (*args, "--name", name, "--resume")

    return refused(args_of, "damaged" if filename == "lock" else "checkpoint")


RUN_FILE_CASES = [
    Case("damaged run files", f"{stage} --resume, lock {how}", _damaged_run_file(stage, "lock", make))
    for stage in RESUMES for how, make in DAMAGED_LOCKS.items()
] + [
    Case("damaged run files", f"{stage} --resume, checkpoint {how}", _damaged_run_file(stage, "checkpoint.pt", make))
    for stage in RESUMES for how, make in DAMAGED_CHECKPOINTS.items()
]


LEDGERED = {"demos": ("ip", "ip2"), "dataset": ("data", "data2"), "embedding": ("ident", "ident2"),
            "discriminator": ("disc", "disc2"), "policy": ("p", "p2")}  # kind: (the stage's artifact, another of its kind)


def _ledger_case(kind: str, damage: Callable[[Context, Path], None]) -> Callable[[Context], str]:
    """A sweep's ledger entry for a finished stage, damaged: the documented meaning is that the stage runs again."""
    def check(ctx: Context) -> bool:
        from lwail_cli.stages.sweep import _once
        from lwail_cli.stages.sweep_plan import plan_from_dict

        plan = plan_from_dict({"name": "sw", "tasks": [ENV], "seeds": [0]}, "test plan")
        name = LEDGERED[kind][0]
        made = []

        def make():  # the stage, standing in: its artifact is already in the store
            made.append(name)
            return ctx.store.resolve(name, kind)

        first = _once(ctx.store, plan, kind, name, {"seed": 0}, make)
        entry = next((ctx.store.root / ".runs" / "sweep" / "sw").glob("*.ref"))
        entry.unlink()
        damage(ctx, entry)
        again = _once(ctx.store, plan, kind, name, {"seed": 0}, make)
        return made == [name, name] and again.ref == first.ref and entry.read_text() == first.ref
    return guarded(check)


def _foreign(ctx: Context, entry: Path, kind: str) -> None:
    entry.write_text(ctx.store.resolve(LEDGERED[kind][1], kind).ref)


DAMAGED_LEDGERS = {
    "binary": lambda ctx, p, kind: p.write_bytes(b"\xff\xfe\x00"),
    "empty": lambda ctx, p, kind: p.write_text(""),
    "naming another artifact of its kind": _foreign,
    "naming another kind": lambda ctx, p, kind: p.write_text("dataset/data@v1" if kind == "demos" else "demos/ip@v1"),
    "naming its artifact by path": lambda ctx, p, kind: p.write_text(str(ctx.store.resolve(LEDGERED[kind][0], kind).path)),
    "a folder": lambda ctx, p, kind: p.mkdir(),
    "a FIFO": lambda ctx, p, kind: os.mkfifo(p),
    "10 MB of text": lambda ctx, p, kind: p.write_bytes(b"demos/" * 2_000_000),
}
LEDGER_CASES = [Case("damaged run files", f"sweep ledger entry of a {kind} {how}: the stage runs again",
                     _ledger_case(kind, lambda ctx, p, damage=damage, kind=kind: damage(ctx, p, kind)))
                for kind in LEDGERED for how, damage in DAMAGED_LEDGERS.items()]


def _forged_manifest(change: Callable[[dict], None]) -> Callable[[Context], str]:
    """A manifest whose hashes a forger recomputed around a missing or mistyped entry: `ls` lists it as DAMAGED,
    `show` refuses it in one line."""
    listed = guarded(_lists_damaged)

    def run(ctx: Context) -> str:
        path = ctx.store.resolve("ip", "demos").path / "manifest.json"
        manifest = json.loads(path.read_text())
        change(manifest)
        if isinstance(manifest.get("files"), dict):
            manifest["hash"] = content_hash(manifest["files"], manifest.get("env"), manifest.get("config"))
        manifest["manifest_hash"] = manifest_hash(manifest)
        path.write_text(json.dumps(manifest))
        outcome = listed(ctx)
        return outcome if outcome != "clean" else refused(lambda ctx: ("show", "demos/ip"), "damaged")(ctx)
    return run


def _lists_damaged(ctx: Context) -> bool:
    result = ctx.cli("ls")
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    row = next(line for line in result.output.splitlines() if " ip " in f" {line} ")
    return result.exit_code == 0 and "DAMAGED" in row


DAMAGED_MANIFESTS = {
    "without env": lambda m: m.pop("env"),
    "env a string": lambda m: m.update(env="InvertedPendulum-v5"),
    "env a list": lambda m: m.update(env=[1, 2]),
    "env without id": lambda m: m["env"].pop("id"),
    "without created": lambda m: m.pop("created"),
    "created a number": lambda m: m.update(created=5),
    "metrics a list": lambda m: m.update(metrics=[1]),
    "files a list": lambda m: m.update(files=["demos.npz"]),
    "parents a dict": lambda m: m.update(parents={"ref": "x"}),
}
MANIFEST_CASES = [Case("damaged run files", f"manifest {how}", _forged_manifest(change)) for how, change in DAMAGED_MANIFESTS.items()]


# ------------------------------------------------------------------------------ malformed arrays
def _zip_bytes(members: dict[str, bytes], compression=zipfile.ZIP_STORED) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression) as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    return buffer.getvalue()


def _npy(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array, allow_pickle=True)
    return buffer.getvalue()


def _demos_arrays(observations=None) -> dict[str, np.ndarray]:
    obs = np.random.default_rng(0).normal(size=(40, 4)).astype(np.float32) if observations is None else observations
    ends = np.zeros(len(obs), dtype=bool)
    ends[19::20] = True
    return {"observations": obs, "episode_ends": ends}


def _npz_of(arrays: dict, compression=zipfile.ZIP_STORED) -> bytes:
    return _zip_bytes({f"{name}.npy": _npy(array) for name, array in arrays.items()}, compression)


def _forged_shape(shape: bytes) -> bytes:
    """A .npz whose 'observations' header declares another shape over the same data, zipped anew (CRCs agree)."""
    arrays = {f"{name}.npy": _npy(array) for name, array in _demos_arrays().items()}
    data = arrays["observations.npy"]
    before = b"'shape': (40, 4), }"
    start = data.index(before)
    padding = data.index(b"\n", start) - start - len(before)  # the header's spaces keep its length
    after = b"'shape': " + shape + b", }"
    arrays["observations.npy"] = data[:start] + after + b" " * (padding - (len(after) - len(before))) + data[start + len(before) + padding:]
    return _zip_bytes(arrays)


def _flipped() -> bytes:
    data = bytearray(_npz_of(_demos_arrays(), zipfile.ZIP_DEFLATED))
    data[len(data) // 3] ^= 0xFF  # inside the compressed data of the first member
    return bytes(data)


def _encrypted() -> bytes:
    data = bytearray(_npz_of(_demos_arrays()))
    for signature, offset in ((b"PK\x03\x04", 6), (b"PK\x01\x02", 8)):  # the general-purpose flags of every header
        for found in re.finditer(re.escape(signature), bytes(data)):
            data[found.start() + offset] |= 0x01
    return bytes(data)


MALFORMED_ARRAYS = {  # label: (what the file holds, part of the one line)
    "a zip of text files": (lambda: _zip_bytes({"observations": b"1 2 3", "episode_ends": b"0 1"}), "not a .npz"),
    "a .npy member that is garbage": (lambda: _zip_bytes({"observations.npy": b"\x93NUMPY garbage"}), "cannot read"),
    "cut short": (lambda: _npz_of(_demos_arrays())[:700], "cannot read"),
    "a flipped byte in its data": (_flipped, "cannot read"),
    "a header declaring 14.6 TiB": (lambda: _forged_shape(b"(1000000000000, 4)"), "declares a float32 array of shape (1000000000000, 4)"),
    "a negative dimension": (lambda: _forged_shape(b"(-40, 4)"), "declares"),
    "a pickled object array": (lambda: _npz_of(_demos_arrays(np.array([{"a": 1}] * 40, dtype=object))), "real numbers"),
    "strings": (lambda: _npz_of(_demos_arrays(np.array([["1.0"] * 4] * 40))), "real numbers"),
    "a structured array": (lambda: _npz_of(_demos_arrays(np.zeros(40, dtype=[("x", "f4"), ("y", "f4")]))), "real numbers"),
    "an encrypted member": (_encrypted, "cannot read"),
    "an empty zip": (lambda: _zip_bytes({}), "has no 'observations'"),
}


def _array_case(command: tuple, content: Callable[[], bytes], message: str) -> Callable[[Context], str]:
    def args_of(ctx: Context) -> tuple:
        path = ctx.tmp / "input.npz"
        path.write_bytes(content())
        return (*command, path)
    return refused(args_of, message)


def _special_file_case(command: tuple, make: Callable[[Path], None], message: str) -> Callable[[Context], str]:
    def args_of(ctx: Context) -> tuple:
        make(ctx.tmp / "input.npz")
        return (*command, ctx.tmp / "input.npz")
    return refused(args_of, message)


def _too_big_case(command: tuple) -> Callable[[Context], str]:
    """A sound .npz larger than the memory available (here: 1 KiB)."""
    def args_of(ctx: Context) -> tuple:
        from lwail_cli.stages import shared

        shared.available_memory = lambda: 1024  # undone by the fixture below
        path = ctx.tmp / "input.npz"
        path.write_bytes(_npz_of(_demos_arrays()))
        return (*command, path)
    return refused(args_of, "needs")


IMPORTS = {"demos import": ("demos", "import", ENV, "--from-file"), "collect": ("collect", ENV, "--from-file")}
ARRAY_CASES = [
    Case("malformed arrays", f"{command} --from-file {how}", _array_case(args, content, message))
    for command, args in IMPORTS.items() for how, (content, message) in MALFORMED_ARRAYS.items()
] + [
    Case("malformed arrays", f"{command} --from-file {how}", _special_file_case(args, make, "not a regular file"))
    for command, args in IMPORTS.items() for how, make in (("a FIFO", os.mkfifo), ("a folder", lambda p: p.mkdir()))
] + [Case("malformed arrays", f"{command} --from-file larger than memory", _too_big_case(args)) for command, args in IMPORTS.items()]


@pytest.fixture(autouse=True)
def _memory_restored(monkeypatch):
    from lwail_cli.stages import shared

    monkeypatch.setattr(shared, "available_memory", shared.available_memory)  # a case may shrink it


# ------------------------------------------------------------------------------ the user's own environment misbehaving
class FaultyEnv(gym.Env):
    """A registered environment with one fault; at step 3 for faults of step()."""

    observation_space = gym.spaces.Box(-np.inf, np.inf, (3,), np.float64)
    action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def __init__(self, fault: str):
        if fault == "its constructor raises":
            raise RuntimeError("no licence server")
        self.fault, self.t = fault, 0

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.t = 0
        if self.fault == "reset raises":
            raise ValueError("cannot reach the simulator")
        if self.fault == "reset raises a message of two lines":
            raise ValueError("first line\nsecond line")
        obs = np.zeros(3)
        if self.fault == "an infinite observation at reset":
            obs[1] = np.inf
        return obs, {}

    def step(self, action):
        self.t += 1
        obs, reward = np.zeros(3), 1.0
        if self.t == 3:
            if self.fault == "step raises":
                raise RuntimeError("the simulator crashed")
            if self.fault == "a NaN observation":
                obs[0] = np.nan
            if self.fault == "an observation of another shape":
                obs = np.zeros(5)
            if self.fault == "a NaN reward":
                reward = float("nan")
            if self.fault == "an infinite reward":
                reward = float("inf")
            if self.fault == "a reward that is no number":
                reward = None
        return obs, reward, False, False, {}


FAULTS = {  # fault: where the one line says it happened
    "its constructor raises": "failed to start",
    "reset raises": "failed at reset",
    "reset raises a message of two lines": "failed at reset",
    "an infinite observation at reset": "failed at reset",
    "step raises": "failed at step 3 of an episode",
    "a NaN observation": "failed at step 3 of an episode",
    "an observation of another shape": "failed at step 3 of an episode",
    "a NaN reward": "failed at step 3 of an episode",
    "an infinite reward": "failed at step 3 of an episode",
    "a reward that is no number": "failed at step 3 of an episode",
}


def _faulty_id(fault: str) -> str:
    return "Faulty" + "".join(word.capitalize() for word in re.findall(r"[a-z]+", fault)) + "-v0"


for _fault in FAULTS:
    gym.register(_faulty_id(_fault), entry_point=FaultyEnv, kwargs={"fault": _fault}, max_episode_steps=50)

ENV_COMMANDS = {
    "collect": lambda env_id: ("collect", env_id, "--transitions", "20"),
    "expert train": lambda env_id: ("expert", "train", env_id, "--steps", "20", "--set", "train.eval_episodes=1"),
}
ENV_CASES = [
    Case("a faulty environment", f"{command}: {fault}",
         refused(lambda ctx, make=make, fault=fault: make(_faulty_id(fault)), f"environment {_faulty_id(fault)!r}" if where == "failed to start"
                 else f"environment {_faulty_id(fault)} {where}"))
    for command, make in ENV_COMMANDS.items() for fault, where in FAULTS.items()
]


# ------------------------------------------------------------------------------ numbers and lists
SEEDED_COMMANDS = {
    "collect": ("collect", ENV, "--transitions", "20"),
    "expert train": ("expert", "train", ENV, "--steps", "20"),
    "expert record": ("expert", "record", "p", "--episodes", "1"),
    "demos import": ("demos", "import", ENV, "--bundled"),
    "pretrain-icvf": ("pretrain-icvf", "data", "--kind", "identity"),
    "warmup-disc": ("warmup-disc", "ident", "ip", "--set", "steps=2"),
    "imitate": ("imitate", ENV, "--demos", "ip", "--embedding", "ident", "--disc", "disc", "--steps", "20"),
}
NUMBER_CASES = [
    Case("numbers and lists", f"{command} --seed {seed}", refused(lambda ctx, args=args, seed=seed: (*args, "--seed", seed), "--seed", exit_code=2))
    for command, args in SEEDED_COMMANDS.items() for seed in (str(2**64), str(2**32))
]

HIDDEN = {  # a list field of each kind, with a command that checks it before anything runs
    "td3.hidden": ("imitate", ENV, "--demos", "no-such-demos", "--embedding", "e", "--disc", "f", "--name", "x"),
    "icvf.hidden": ("pretrain-icvf", "no-such-data", "--name", "x"),
    "critic.hidden": ("warmup-disc", "no-such-embedding", "no-such-demos", "--name", "x"),
}
MALFORMED_LISTS = ("[32", "32]", "1,,2", "(32]", "[[32]]", ",32", "3 2", "[,]", "32,,")
LIST_CASES = [
    Case("numbers and lists", f"--set {key}={text}", refused(lambda ctx, args=args, key=key, text=text: (*args, "--set", f"{key}={text}"), key))
    for key, args in HIDDEN.items() for text in MALFORMED_LISTS
]


def _linear_actor(ctx: Context) -> bool:
    """hidden=[] is documented (`--set` help) as no hidden layer: the actor is one linear map (then tanh)."""
    result = ctx.cli("expert", "train", ENV, "--steps", "20", "--set", "td3.hidden=[]", "--set", "train.eval_episodes=1", "--name", "linear")
    from safetensors.numpy import load_file

    policy = ctx.store.resolve("linear", "policy")
    layers = {key for key in load_file(policy.file("actor.safetensors")) if key.startswith("net.")}
    return result.exit_code == 0 and policy.config["td3"]["hidden"] == [] and layers == {"net.0.weight", "net.0.bias"}


TOGETHER = {  # two assignments valid only together, checked across fields: either order is the same config
    "td3.learning_starts=100 with td3.batch_size=32": (cfg.ExpertConfig, ["td3.learning_starts=100", "td3.batch_size=32"]),
    "train.policy=average with train.average_tau=0.001": (cfg.ExpertConfig, ["train.policy=average", "train.average_tau=0.001"]),
    "icvf.p_goal_current=0.6 with icvf.p_goal_trajectory=0.3": (cfg.EmbedConfig, ["icvf.p_goal_current=0.6", "icvf.p_goal_trajectory=0.3"]),
}


def _in_order(config_class, assignments: list[str]) -> Callable[[Context], bool]:
    def check(ctx: Context) -> bool:
        built = cfg.with_overrides(config_class(), assignments)
        return all(str(getattr(built, key.split(".")[0]).__dict__[key.split(".")[1].split("=")[0]]) == key.split("=")[1] for key in assignments)
    return check


ORDER_CASES = [
    Case("numbers and lists", f"--set {pair}, {order}", guarded(_in_order(config_class, assignments if order == "in this order" else assignments[::-1])))
    for pair, (config_class, assignments) in TOGETHER.items() for order in ("in this order", "the other way round")
] + [
    Case("numbers and lists", "--set td3.hidden=[] is a linear map", guarded(_linear_actor)),
    Case("numbers and lists", "--set td3.batch_size given twice", refused(
        lambda ctx: (*HIDDEN["td3.hidden"], "--set", "td3.batch_size=32", "--set", "td3.batch_size=64"), "given twice")),
]


# ------------------------------------------------------------------------------ silently ignored or sloppy arguments
REFS_WITH_A_NEWLINE = {
    "eval": ("eval", "p\n"),
    "show": ("show", "policy/p\n"),
    "verify": ("verify", "policy/p@v1\n"),
    "pretrain-icvf": ("pretrain-icvf", "data\n", "--kind", "identity"),
    "curve": ("curve", "p\n"),
    "expert record": ("expert", "record", "p\n", "--episodes", "1"),
    "warmup-disc": ("warmup-disc", "ident", "ip\n", "--set", "steps=2"),
}
NAMED_COMMANDS = {
    "collect": ("collect", ENV, "--transitions", "20"),
    "expert train": ("expert", "train", ENV, "--steps", "20", "--set", "train.eval_episodes=1"),
    "expert record": ("expert", "record", "p", "--episodes", "1"),
    "demos import": ("demos", "import", ENV, "--bundled"),
    "pretrain-icvf": ("pretrain-icvf", "data", "--kind", "identity"),
    "warmup-disc": ("warmup-disc", "ident", "ip", "--set", "steps=2"),
    "imitate": ("imitate", ENV, "--demos", "ip", "--embedding", "ident", "--disc", "disc", "--steps", "20"),
}


def _minari_case(command: tuple, change: Callable[[dict], None]) -> Callable[[Context], str]:
    """A dataset in the local Minari store whose metadata says it was written by a Minari this one cannot read."""
    def args_of(ctx: Context) -> tuple:
        data = ctx.tmp / "minari" / "local" / "future-v0" / "data"
        shutil.copytree(ctx.store.resolve("data", "dataset").file("minari"), data)
        metadata = json.loads((data / "metadata.json").read_text())
        change(metadata)
        (data / "metadata.json").write_text(json.dumps(metadata))
        os.environ["MINARI_DATASETS_PATH"] = str(ctx.tmp / "minari")  # restored by the fixture below
        return (*command, ENV, "--from-minari", "local/future-v0")
    return refused(args_of, "Minari")


@pytest.fixture(autouse=True)
def _minari_path_restored(monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", os.environ.get("MINARI_DATASETS_PATH", ""))


ARGUMENT_CASES = [
    Case("sloppy arguments", "eval p --demos nope (no --normalized)", refused(lambda ctx: ("eval", "p", "--demos", "nope"), "--normalized")),
    Case("sloppy arguments", "eval p --demos ip (no --normalized)", refused(lambda ctx: ("eval", "p", "--demos", "ip"), "--normalized")),
] + [
    Case("sloppy arguments", f"{command} with a ref ending in a newline", refused(lambda ctx, args=args: args, "is neither an artifact path nor a name"))
    for command, args in REFS_WITH_A_NEWLINE.items()
] + [
    Case("sloppy arguments", f"{command} --name ''", refused(lambda ctx, args=args: (*args, "--name", ""), "artifact name ''"))
    for command, args in NAMED_COMMANDS.items()
] + [
    Case("sloppy arguments", f"{' '.join(command)} --from-minari, {how}", _minari_case(command, change))
    for command in (("demos", "import"), ("collect",))
    for how, change in (("a future Minari format", lambda m: m.update(minari_version="99.0.0")),
                        ("no Minari version", lambda m: m.pop("minari_version")))
]


# ------------------------------------------------------------------------------ refusals that change the store
def _refused_resume(stage: str, message: str, stale_lock: bool, extra: tuple = (), swap: tuple | None = None) -> Callable[[Context], str]:
    """The resume of a killed run with ``extra`` options, or with the input ``swap[0]`` replaced by ``swap[1]``."""
    kind, name, args = RESUMES[stage]

    def args_of(ctx: Context) -> tuple:
        if stale_lock:  # a lock a killed process left: taken over by a run that goes ahead, kept by a refused one
            (ctx.run_folder(stage) / "lock").write_text(f"{socket.gethostname()} {_dead_pid()}")
        resumed = [swap[1] if swap is not None and arg == swap[0] else arg for arg in args]
        return (*resumed, "--name", name, "--resume", *extra)
    return refused(args_of, message)


OTHER_RUNS = {  # stage: what differs from the killed run -> (options, or the input swapped, and the refusal)
    "expert-train": {"another seed": ((("--seed", "1"), None), "made with another seed;"),
                     "another config": ((("--set", "td3.tau=0.01"), None), "made with another config;"),
                     "another env": (((), (ENV, "InvertedDoublePendulum-v5")), "made with another env;")},
    "imitate": {"another seed": ((("--seed", "1"), None), "made with another seed;"),
                "another config": ((("--set", "td3.tau=0.01"), None), "made with another config;"),
                "other demos": (((), ("ip", "ip2")), "made with another parents;")},
    "pretrain-icvf": {"another seed": ((("--seed", "1"), None), "made with another seed;"),
                      "another config": ((("--set", "icvf.lr=0.001"), None), "made with another config;"),
                      "other data": (((), ("data", "data2")), "made with another parents;")},
}
REFUSAL_CASES = [
    Case("refusals change nothing", f"{stage} --resume with {other}{', beside a stale lock' if stale else ''}",
         _refused_resume(stage, message, stale, *change))
    for stage, others in OTHER_RUNS.items() for other, (change, message) in others.items() for stale in (False, True)
] + [
    Case("refusals change nothing", f"{stage} --resume without a checkpoint", refused(
        lambda ctx, args=args, name=name: (*args, "--name", f"never-{name}", "--resume"), "no checkpoint"))
    for stage, (kind, name, args) in RESUMES.items()
]


def _resumes(stage: str) -> Callable[[Context], bool]:
    kind, name, args = RESUMES[stage]

    def check(ctx: Context) -> bool:
        (ctx.run_folder(stage) / "lock").write_text(f"{socket.gethostname()} {_dead_pid()}")
        result = ctx.cli(*args, "--name", name, "--resume")
        return result.exit_code == 0 and ctx.store.resolve(name, kind).version == 1 and not ctx.run_folder(stage).exists()
    return check


SOUND_CASES = [Case("refusals change nothing", f"{stage} --resume with the same options goes ahead (a stale lock taken over)",
                    guarded(_resumes(stage))) for stage in RESUMES]

CASES = (RUN_FILE_CASES + LEDGER_CASES + MANIFEST_CASES + ARRAY_CASES + ENV_CASES + NUMBER_CASES + LIST_CASES + ORDER_CASES
         + ARGUMENT_CASES + REFUSAL_CASES + SOUND_CASES)


def test_the_second_catalogue_covers_every_family():
    families = {case.family for case in CASES}
    assert len(CASES) >= 40 and len(families) == 6 and len({case.id for case in CASES}) == len(CASES)


@pytest.mark.parametrize("case", CASES, ids=lambda case: case.id)
def test_each_bad_input_is_one_clean_line_or_its_documented_meaning(ctx, case):
    outcome = case.run(ctx)
    assert outcome == "clean", outcome
