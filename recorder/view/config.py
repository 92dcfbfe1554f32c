"""ViewConfig: what `gloverec view` shows: the session (SessionConfig, recorder/rig/config.py: --glove, --robot,
--task, --retarget, --wearer, --wrist, --wrist-camera, --wrist-mount, --marker-mm, --glove-rate, --glove-output, as
`gloverec record` names them) and how it is shown. Its flags are generated from these fields (recorder/config.py)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

from pydantic import AfterValidator

from recorder.config import Positive, setting
from recorder.rig.config import SessionConfig
from recorder.view.process import ViewSpec


def checked_view(text: str) -> str:
    """A view spec, checked (RecordConfig's too): ConfigError (a ValueError) names what is valid."""
    ViewSpec.parse(text)
    return text


View = Annotated[str, AfterValidator(checked_view)] | None  # a command's --view field (record's, view's)


def view_setting(help: str):
    """A command's --view field: no view named by default (the command says which it then opens)."""
    return setting(None, help, metavar="VIEW", check=ViewSpec.parse)


@dataclass
class ViewConfig(SessionConfig):
    view: View = view_setting(
        "native (MuJoCo's viewer), web[:PORT] (a page on 127.0.0.1), rerun[:MODE], none (default: native with a "
        "display; none with --video)"
    )
    video: str | None = setting(None, "also film the view: into FILE.mp4, or into this folder as view-TIME.mp4 (with "
                                "no --view: instead of one)", metavar="FILE.mp4|DIR")  # fmt: skip
    duration: Annotated[float, Positive] | None = setting(
        None, "seconds (default: until Ctrl-C; 10 s for a video from the emulator)", metavar="S"
    )

    def task_options(self) -> dict:
        """The task's endless live scene (the task registry's ``live`` settings); with a tracked wrist the wearer
        places the base, and a scene lasts until "next", which zeroes the wrist again."""
        from envs.tasks import get_task  # MuJoCo (0.2 s): not at start-up

        options = dict(get_task(self.task).live)
        if self.tracked:
            options.update(self.tracked_options(), episode_s=1e9, terminate_on_success=False)
        return options
