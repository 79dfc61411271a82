"""Checkpoints of long runs: stop anywhere, resume in a new process, the same result bit for bit.

``mechfmu run SCENE --checkpoint FILE`` writes FILE every ``--checkpoint-every`` seconds of wall
time and when SIGINT or SIGTERM stops the run; ``mechfmu run SCENE --resume FILE`` continues from it. A
checkpoint holds, at one communication point, every component's FMU state serialised by the
FMU itself (fmi2SerializeFMUstate / fmi3SerializeFMUState: our FMUs write their state as
bit-exact JSON, see runtime/fmi/state.py) and the rows the run still holds in memory, in the
recorders' own bytes; the resumed run restores the states and the rows and steps on, so its
result equals the uninterrupted run's, row for row and bit for bit.

A long run does not keep its rows: it streams them to its result file and lets them go
(results.StreamedResult; Simulation.run(keep=False)). Its checkpoint then holds none of
them, only how many were streamed (``streamed``) and where the file stood (``stream``: the
CSV's size and SHA-256 at that row, or the Parquet rows, and the plot's sample): a bounded
size whatever the run's length. Resuming such a checkpoint continues that file in the same
output folder (the ``.partial`` file a stopped or killed run leaves): checked, cut back to
the checkpoint's row, and written on.

The file is JSON, versioned (FORMAT, VERSION) and checked before anything is restored: the
scene (a digest of its resolved settings: times, components, parameters, connections,
records), every component's FMU (its guid or instantiation token: a rebuilt FMU cannot take
an old state) and the recorded rows must match; a CheckpointError (a SceneError: exit 2)
names what does not.
"""

from __future__ import annotations

import base64
import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .files import atomic_write
from .scene import SceneError

if TYPE_CHECKING:  # annotations only
    from .scene import Scene

FORMAT, VERSION = "mechfmu-checkpoint", 1


class CheckpointError(SceneError):
    """A checkpoint that cannot be written or resumed; the message says why."""


@dataclass(frozen=True)
class Checkpoints:
    """Where a run writes its checkpoints: at the communication points ``steps`` apart and,
    besides, when ``seconds`` of wall time have passed since the last (0: not on that
    account), and always when a signal stops the run."""

    path: Path
    steps: int = 0
    seconds: float = 0.0


def scene_digest(scene: Scene) -> str:
    """SHA-256 of the scene's resolved settings (what decides its result)."""
    settings = {
        "times": [scene.start_time, scene.stop_time, scene.step],
        "coupling": scene.coupling,
        "record": scene.record,
        "connections": [str(c) for c in scene.connections],
        "components": {
            name: {
                "fmu": spec.fmu,
                "parameters": spec.parameters,
                "inputs": spec.inputs,
                "effects": spec.effects,
            }
            for name, spec in scene.components.items()
        },
    }
    text = json.dumps(settings, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


@dataclass
class Checkpoint:
    """A run at communication point ``index`` (time ``time``, s): each component's guid and
    serialised FMU state, each recorder's rows still in memory ((typecode, bytes) by key) and
    their ``times``; the ``streamed`` rows before them were let go to the result file, which
    stood at ``stream`` (StreamedResult.position; None when nothing was let go)."""

    scene: str
    digest: str
    index: int
    time: float
    guids: dict[str, str]
    states: dict[str, bytes]
    rows: dict[str, tuple[str, bytes]]
    times: list[float] = field(default_factory=list)
    streamed: int = 0
    stream: dict[str, Any] | None = None

    def to_json(self) -> str:
        def encoded(data: bytes) -> str:
            return base64.b64encode(data).decode("ascii")

        return json.dumps(
            {
                "format": FORMAT,
                "version": VERSION,
                "scene": self.scene,
                "digest": self.digest,
                "index": self.index,
                "time": self.time,
                "components": {
                    name: {"guid": self.guids[name], "state": encoded(self.states[name])}
                    for name in self.states
                },
                "rows": {
                    key: {"typecode": code, "data": encoded(data)}
                    for key, (code, data) in self.rows.items()
                },
                "times": self.times,
                "streamed": self.streamed,
                "stream": self.stream,
            }
        )


def save(path: Path, checkpoint: Checkpoint) -> Path:
    """Write ``checkpoint`` to ``path`` atomically (a reader never sees half a file)."""
    return atomic_write(path, checkpoint.to_json())


def load(path: Path) -> Checkpoint:
    """The checkpoint in ``path``; CheckpointError naming the file and what is wrong."""

    def refuse(why: str) -> CheckpointError:
        return CheckpointError(f"checkpoint {path}: {why}")

    try:
        document = json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise refuse("not found") from None
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as error:
        raise refuse(f"cannot be read ({error})") from None
    if not isinstance(document, dict) or document.get("format") != FORMAT:
        raise refuse("is not a mechfmu checkpoint")
    if document.get("version") != VERSION:
        raise refuse(f"is version {document.get('version')!r}; this mechfmu reads {VERSION}")
    try:
        return Checkpoint(
            scene=str(document["scene"]),
            digest=str(document["digest"]),
            index=int(document["index"]),
            time=float(document["time"]),
            guids={name: str(c["guid"]) for name, c in document["components"].items()},
            states={
                name: base64.b64decode(c["state"], validate=True)
                for name, c in document["components"].items()
            },
            rows={
                key: (str(r["typecode"]), base64.b64decode(r["data"], validate=True))
                for key, r in document["rows"].items()
            },
            times=[float(t) for t in document["times"]],
            streamed=int(document["streamed"]),
            stream=_stream(document["stream"]),
        )
    except (KeyError, TypeError, ValueError, AttributeError) as error:
        raise refuse(f"is damaged ({error!r})") from None


def check_matches(checkpoint: Checkpoint, scene: Scene, guids: dict[str, str]) -> None:
    """CheckpointError unless ``checkpoint`` was taken by a run of ``scene`` with FMUs of the
    ``guids`` (component -> guid or instantiation token)."""
    if checkpoint.digest != scene_digest(scene):
        raise CheckpointError(
            f"the checkpoint was taken by a run of scene {checkpoint.scene!r} with other "
            f"settings than {scene.name!r} has now (times, components, parameters, "
            "connections or records changed): it cannot be resumed"
        )
    for name, guid in guids.items():
        if checkpoint.guids.get(name) != guid:
            raise CheckpointError(
                f"component {name!r}: its FMU is not the one the checkpoint was taken with "
                f"(guid {checkpoint.guids.get(name)!r}, now {guid!r}: rebuilt since?)"
            )
    held = checkpoint.streamed + len(checkpoint.times)
    if held != checkpoint.index + 1 or (checkpoint.streamed > 0) != (checkpoint.stream is not None):
        raise CheckpointError(
            f"the checkpoint has {checkpoint.streamed} streamed and {len(checkpoint.times)} "
            f"held rows for communication point {checkpoint.index}: it is damaged"
        )


def _stream(stream: Any) -> dict[str, Any] | None:
    """A checkpoint's ``stream`` entry: None or a dict (TypeError otherwise)."""
    if stream is not None and not isinstance(stream, dict):
        raise TypeError(f"stream is {type(stream).__name__}, not an object")
    return stream
