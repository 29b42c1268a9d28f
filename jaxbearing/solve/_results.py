"""The result codes of a solve: diffrax's, and those of the segmented, event-located solve."""

from __future__ import annotations

import diffrax


class RESULTS(diffrax.RESULTS):
    """diffrax's result codes plus the ones of the segmented solve."""

    max_segments_reached = (
        "More iterations than max_segments x segment_steps allow (each step, accepted or "
        "rejected, and each step of an event's root finder is one). Increase `max_segments` "
        "(jaxbearing.SolveOptions)."
    )
    max_onsets_reached = (
        "More episode onsets (contact onsets) than max_onsets records. Increase `max_onsets` "
        "(jaxbearing.SolveOptions)."
    )
    contact_overlap = (
        "An event value jumped across zero instead of crossing it, e.g. a contact switched on "
        "(its active_from) while its surfaces overlap: switch it on when they are apart."
    )
    event_not_located = (
        "The event's root finder did not narrow an event time within its steps: "
        "the event value is likely not finite along the step."
    )
    invalid_input = (
        "A parameter value, the initial state or the times are outside what is allowed (the "
        "error raised with throw=True names which); nothing was integrated."
    )
