"""Debian's chromium, headless, on a local page: its DOM after the page ran, a screenshot, and the
hosts it asked for (a NetLog). Network requests go to a closed local port (--proxy-server), so a
page that needed the network would fail to draw as well as show up in the log."""
import html
import json
import os
import re
import shutil
import subprocess

WIDTH, HEIGHT = 960, 540

# Chromium's own services, which it may call at any moment whatever the page (seen on 156 with
# the flags below): exact hosts, so a CDN a page might load from (ajax.googleapis.com, ...) still counts.
BROWSER_HOSTS = {"clients2.google.com", "update.googleapis.com", "accounts.google.com", "redirector.gvt1.com",
                 "optimizationguide-pa.googleapis.com", "content-autofill.googleapis.com",
                 "safebrowsing.googleapis.com", "www.google.com", "clientservices.googleapis.com"}


def find():
    return shutil.which("chromium")


def run(url, work, name, extra, budget_ms=4000):
    """Runs chromium on `url` with `extra` flags; returns its stdout. `name` keeps each run's
    profile (and files) apart."""
    profile = os.path.join(work, "chromium-" + name)
    shutil.rmtree(profile, ignore_errors=True)
    cmd = [find(), "--headless", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
           f"--user-data-dir={profile}", f"--window-size={WIDTH},{HEIGHT}", "--hide-scrollbars",
           f"--virtual-time-budget={budget_ms}", "--proxy-server=127.0.0.1:9", "--disable-background-networking",
           "--disable-component-update", "--disable-sync", "--disable-extensions", "--no-first-run",
           "--disable-features=OptimizationHints,OptimizationHintsFetching,OptimizationGuideModelDownloading",
           "--mute-audio"] + extra + [url]
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=180, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"chromium exited {r.returncode} on {url}: {r.stderr[-2000:]}")
    return r.stdout


def status(url, work, name):
    """The JSON the page keeps in <pre id="f16race-status"> (apps/viewer/race_viewer.js)."""
    dom = run(url, work, name, ["--dump-dom"])
    m = re.search(r'<pre id="f16race-status"[^>]*>(.*?)</pre>', dom, re.S)
    if not m or not m.group(1).strip():
        raise RuntimeError(f"{url}: the page wrote no status (did its script run?)")
    return json.loads(html.unescape(m.group(1)))


def screenshot(url, work, name):
    png = os.path.join(work, name + ".png")
    if os.path.exists(png):
        os.remove(png)
    run(url, work, name, [f"--screenshot={png}"])
    if not os.path.isfile(png):
        raise RuntimeError(f"{url}: chromium wrote no screenshot")
    return png


def requested_hosts(url, work, name):
    """Hosts of the http(s) requests made while `url` was open, but for chromium's own services."""
    log = os.path.join(work, name + "-netlog.json")
    run(url, work, name, [f"--log-net-log={log}", "--dump-dom"])
    text = open(log, encoding="utf-8", errors="replace").read()
    return set(re.findall(r'"url":"https?://([^/":?]+)', text)) - BROWSER_HOSTS
