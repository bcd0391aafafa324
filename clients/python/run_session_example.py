#!/usr/bin/python3
"""Example: run the standard session on chromod and wait for its result.

    python3 clients/python/run_session_example.py [TARGET] [--token T]   (default: chromod's default socket)

Prints one progress line per update, then the session folder, the result
state, the stored frame count and where the time went. Exit status 0 when the session succeeded.
"""
import argparse
import sys

from chromosphere_client import Client, default_target, state_name


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("target", nargs="?", default=None)
    parser.add_argument("--token", default=None, help="bearer token (TCP)")
    parser.add_argument("--subject", default="python example")
    args = parser.parse_args()

    client = Client(args.target or default_target(), token=args.token)
    for device in client.list_devices():
        print(f"device {device.name}: {device.backend} {device.address} health={device.health}")
    operation = client.start_standard_session(subject=args.subject)
    print(f"started session {operation.id}")

    def show(op):
        c = op.counters
        print(f"  {state_name(op.state):<10} {op.progress * 100:5.1f}% eta {op.eta_seconds:5.1f}s "
              f"stored {c.stored}/{c.expected} lost {c.lost}  {op.message}")

    final = client.wait(operation.id, on_update=show)
    results = client.results(operation.id)
    print(f"session {final.id}: {state_name(final.state)}")
    print(f"folder: {results.folder}")
    print(f"frames stored: {final.counters.stored}")
    print(f"results: {results.state} {results.reason}")
    timeline = client.session(operation.id).timeline
    print(f"timeline: capture {timeline.capture_s:.1f} s (subject {timeline.subject_s:.1f} s), "
          f"maps {timeline.estimation_s:.1f} s after the last frame, total {timeline.total_s:.1f} s")
    client.close()
    return 0 if state_name(final.state) == "succeeded" else 1


if __name__ == "__main__":
    sys.exit(main())
