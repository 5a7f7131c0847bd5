"""viewer_headless: `f16race replay --html` writes a page that headless Chromium renders offline.

Replays the shipped team (examples/trained_team, issue 52's acceptance) against the autopilot with
--html, then checks in Debian's chromium: the page sets its ready flag with WebGL on; it reads back 8
aircraft, the race length replay printed and the frame a #t= slider position selects; its
leader is further along the track later on; screenshots are not blank and differ between two
moments; and it asks for no host a blank page does not. Exit 77 (skipped) only without chromium.

usage: viewer_headless.py F16RACE SHIPPED_TEAM_DIR WORK_DIR
"""
import os
import re
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import headless_chromium as chrome  # noqa: E402
from png_stats import read_png_rgb  # noqa: E402

SKIP = 77
failures = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what)
    if not ok:
        failures.append(what)


def sh(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=600)
    if r.returncode != 0:
        sys.exit(f"FAIL: {' '.join(cmd)} exited {r.returncode}:\n{r.stdout}")
    return r.stdout


def make_page(f16race, team, work):
    page = os.path.join(work, "race.html")
    out = sh([f16race, "replay", "--run", team, "--opponent", "autopilot", "--seed", "2",
              "--out", os.path.join(work, "replay"), "--html", page])
    m = re.search(r"after ([0-9.]+) s", out)
    if not m:
        sys.exit(f"FAIL: replay printed no race length:\n{out}")
    return page, float(m.group(1))


def check_file(page):
    text = open(page, encoding="utf-8").read()
    size = os.path.getsize(page)
    check(size < 3e6, f"page is {size / 1e6:.2f} MB (< 3 MB)")
    remote = re.findall(r"""(?:src|href)\s*=\s*["']?\s*(?:https?:)?//|url\(\s*["']?(?:https?:)?//|@import""", text)
    check(not remote, f"no script, style or image from the network in the file ({len(remote)} found)")
    check("window.f16raceReady" in text and "THREE.WebGLRenderer" in text, "three.js and the viewer inlined")


def main():
    f16race, team, work = sys.argv[1:4]
    if chrome.find() is None:
        print("SKIP: chromium is not installed (scripts/setup.sh installs it): the replay page was not rendered")
        return SKIP
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    page, printed_s = make_page(f16race, team, work)
    check_file(page)
    url = "file://" + os.path.abspath(page)

    st = chrome.status(url + "#t=4", work, "t4")
    check(st["ready"] is True and st["webgl"] is True, f"ready flag set with WebGL on ({st['ready']}, {st['webgl']})")
    check(st["aircraft"] == 8, f"8 aircraft read back ({st['aircraft']})")
    check(abs(st["duration_s"] - printed_s) <= 0.05 and st["duration_s"] > 0,
          f"race length {st['duration_s']} s is replay's {printed_s} s")
    check(abs(st["dt_s"] - 0.08) < 1e-9, f"samples every LL step of 0.08 s ({st['dt_s']})")
    check(abs(st["frames"] * st["dt_s"] - st["duration_s"]) <= st["dt_s"] + 1e-6,
          f"{st['frames']} frames span the race")
    check(st["frame"] == 50 and abs(st["time_s"] - 4.0) < 1e-9 and st["playing"] is False,
          f"#t=4 shows frame 50 at 4 s, paused (frame {st['frame']}, {st['time_s']} s)")

    late = min(20.0, st["duration_s"] - 1.0)
    check(late >= 10.0, f"the race lasts past 11 s ({st['duration_s']} s)")
    early_st, late_st = chrome.status(url + "#t=2", work, "t2"), chrome.status(url + f"#t={late}", work, "tlate")
    check(late_st["leader_s_ft"] > early_st["leader_s_ft"] + 3000,
          f"the leader moved along the tube: {early_st['leader_s_ft']} ft at 2 s, {late_st['leader_s_ft']} ft at {late} s")

    # The 3-D view alone (&ui=0 hides the panels, whose text would pass both checks by itself).
    shots = [read_png_rgb(chrome.screenshot(url + f"#t={t}&ui=0", work, f"shot_{n}")) for n, t in (("early", 2), ("late", late))]
    for name, img in zip(("2 s", f"{late} s"), shots):
        check(img.shape == (chrome.HEIGHT, chrome.WIDTH, 3), f"screenshot at {name} is {chrome.WIDTH}x{chrome.HEIGHT}")
        check(img.std() > 6.0, f"screenshot at {name} is not blank (pixel std {img.std():.1f} > 6; one colour: 0)")
    changed = (abs(shots[0] - shots[1]).max(axis=2) > 24).mean()
    check(changed > 0.002, f"the screenshots at 2 s and {late} s differ ({100 * changed:.2f} % of pixels)")

    baseline = chrome.requested_hosts("about:blank", work, "net_blank")
    hosts = chrome.requested_hosts(url + "#t=4", work, "net_page")
    check(not (hosts - baseline), f"the page asked for no host ({sorted(hosts - baseline)} beyond chromium's own)")

    print(f"{len(failures)} failed" if failures else "viewer_headless: all checks passed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
