"""Clip sources: rendered synthetic demonstrators, video files and cameras."""

from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import SCENARIOS, ClipSpec, get_scenario, scenario_names
from imimic_gym.clips.synthetic import render_clip
from imimic_gym.clips.types import Clip, ClipTruth
from imimic_gym.clips.video import stream_video
from imimic_gym.clips.video_load import load_video

__all__ = [
    "SCENARIOS", "Clip", "ClipSpec", "ClipTruth", "get_scenario", "load_clip", "load_video",
    "render_clip", "scenario_names", "stream_video",
]
