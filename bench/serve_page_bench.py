#!/usr/bin/env python3
"""How fast `udvr serve`'s page follows the mouse (issue 13, point 5): drives the real page in
Debian's headless chromium on the 64³ tangle at quantile-mean (q = 8), 512² frames, and reports
the time from a mouse event to the pixels on the page (the page measures it: from its event
handler to the animation frame after the decoded image is drawn) for the coarse frames while
dragging and the full frame after the release. Not a test: the numbers go in docs/serve.md.

    python3 bench/serve_page_bench.py [--udvr build/udvr] [--drags 30] [--threads N]
"""
import argparse
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--udvr", default=str(ROOT / "build" / "udvr"))
    ap.add_argument("--drags", type=int, default=30, help="drag gestures (each: moves, release)")
    ap.add_argument("--moves", type=int, default=8, help="mouse moves per drag")
    ap.add_argument("--model", default="quantile-mean")
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--dump", action="store_true", help="print every timing")
    a = ap.parse_args()
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.support.ui import Select

    d = pathlib.Path(tempfile.mkdtemp(prefix="udvr_serve_bench_"))
    run = lambda *args: subprocess.run([a.udvr, *map(str, args)], check=True,
                                       capture_output=True)
    run("generate", "tangle", "--dims", "64", "-o", d / "tangle.vti")
    run("perturb", d / "tangle.vti", "--members", "20", "--noise", "bimodal", "-o", d / "ens.nc")
    run("build", d / "ens.nc", "--quantiles", "8", "-o", d / "model.vti")
    server = subprocess.Popen([a.udvr, "--threads", str(a.threads), "serve", d / "model.vti",
                               "--tf", ROOT / "data" / "tf" / "tangle.json", "--port", "0"],
                              stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    url = server.stdout.readline().split()[2]
    options = Options()
    options.binary_location = "/usr/bin/chromium"
    for arg in ["--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1500,1000"]:
        options.add_argument(arg)
    driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)

    def idle():
        end = time.time() + 60
        while not driver.execute_script("return !!(window.udvr && window.udvr.idle())"):
            if time.time() > end:
                raise RuntimeError("the page did not settle")
            time.sleep(0.01)

    try:
        driver.get(url)
        idle()
        Select(driver.find_element("id", "model")).select_by_value(a.model)
        idle()
        canvas = driver.find_element("css selector", "figure[data-channel=main] canvas")
        driver.execute_script("window.udvr.state.timings.length = 0")
        for g in range(a.drags):
            chain = ActionChains(driver, duration=16).move_to_element(canvas).click_and_hold()
            for _ in range(a.moves):
                chain = chain.move_by_offset(6, 2 if g % 2 == 0 else -2)  # never back to a cached view
                chain = chain.pause(0.03)
            chain.release().perform()
            idle()
        t = driver.execute_script("return window.udvr.state.timings")
        if "--dump" in sys.argv[1:]: print([(x["kind"][0], round(x["latency"]), round(x["render"])) for x in t])
    finally:
        driver.quit()
        server.terminate()
        server.wait()
    cpu = subprocess.run(["nproc"], capture_output=True, text=True).stdout.strip()
    print(f"64^3 tangle, {a.model} (q=8), 512x512, {cpu} cores, {a.drags} drags")
    for kind in ("coarse", "full"):
        lat = sorted(x["latency"] for x in t if x["kind"] == kind)
        ren = sorted(x["render"] for x in t if x["kind"] == kind)
        if not lat:
            continue
        p90 = lat[min(len(lat) - 1, int(0.9 * len(lat)))]
        print(f"{kind:6s} frames {len(lat):4d}: mouse event -> pixels median "
              f"{statistics.median(lat):6.1f} ms, p90 {p90:6.1f} ms; server render median "
              f"{statistics.median(ren):6.1f} ms")
        # Where the time goes (medians of each part, ms): the server's answer beyond the render
        # (gate, conversion), the way there and back (HTTP), the page (draw, next frame).
        part = lambda f: statistics.median(f(x) for x in t if x["kind"] == kind)
        if all("server" in x and "arrived" in x for x in t):
            print(f"       parts: server past the render {part(lambda x: x['server'] - x['render']):5.1f},"
                  f" HTTP and the page's fetch {part(lambda x: x['arrived'] - x['server']):5.1f},"
                  f" draw to the next animation frame {part(lambda x: x['latency'] - x['arrived']):5.1f}")


if __name__ == "__main__":
    sys.exit(main())
