"""`udvr serve`'s page in Debian's headless chromium: after loading, dragging, zooming, moving a TF
point, switching the model and a click probe, the image in the page is `udvr render`'s of the
same state pixel for pixel, and the probe's numbers are `udvr probe --json`'s."""
import base64
import json
import shutil
import time

import numpy as np
import pytest

from conftest import ROOT
from serve_util import (Server, cli_probe, cli_render, make_inputs, png_pixels, tf2_at,
                        tf2_raster)

CHROMIUM = shutil.which("chromium")
DRIVER = shutil.which("chromedriver")
try:
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys
    from selenium.webdriver.support.ui import Select
except ImportError:  # pragma: no cover - setup.sh installs python3-selenium
    webdriver = None

pytestmark = pytest.mark.skipif(
    webdriver is None or not CHROMIUM or not DRIVER,
    reason="needs chromium, chromium-driver and python3-selenium (scripts/setup.sh installs them)")


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    return make_inputs(tmp_path_factory.mktemp("serve_page"))


@pytest.fixture(scope="module")
def server(inputs):
    s = Server(inputs.model, "--tf", inputs.tf)
    yield s
    s.stop()


def open_page(url):
    """Headless chromium on the page, settled at 256² frames (quick)."""
    options = Options()
    options.binary_location = CHROMIUM
    for a in ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
              "--window-size=1400,1000"]:
        options.add_argument(a)
    driver = webdriver.Chrome(service=Service(DRIVER), options=options)
    driver.set_script_timeout(30)
    try:
        driver.get(url + "/")
        wait_idle(driver)
        driver.start_size = (driver.execute_script("return window.udvr.state.size"),
                             driver.find_element("id", "size").get_attribute("value"))
        Select(driver.find_element("id", "size")).select_by_value("256")  # quick frames
        wait_idle(driver)
    except BaseException:
        driver.quit()
        raise
    return driver


@pytest.fixture(scope="module")
def page(server):
    driver = open_page(server.url)
    try:
        yield driver
    finally:
        driver.quit()


def wait_idle(driver, timeout=30):
    """Until every view shows the full frame of the page's current state."""
    end = time.time() + timeout
    while time.time() < end:
        if driver.execute_script("return !!(window.udvr && window.udvr.idle())"):
            return
        time.sleep(0.05)
    status = driver.execute_script("return document.getElementById('status').textContent")
    views = driver.execute_script(
        "const s = window.udvr.state; return {busy: s.posters.map(p => p.busy), probing: s.probing,"
        " views: [...s.views.values()]"
        "   .map(v => [v.channel, v.pending, v.inFlight.size, v.shown])};")
    raise AssertionError(f"page not idle after {timeout} s; status: {status!r}; {views}")


def page_state(driver):
    return driver.execute_script(
        "const s = window.udvr.state; return {model: s.model, camera: window.udvr.cameraParams()};")


def assert_page_is_cli(driver, server, inputs, tmp_path, tf2=False, tf=None):
    """The main view's PNG and canvas pixels equal `udvr render` of the page's state (its TF, or
    with tf2 its 2D TF: the file `tf`, else as saved from the server)."""
    state = page_state(driver)
    if tf is None:
        tf = tmp_path / "page_tf.json"
        tf.write_bytes(server.get("/api/tf2" if tf2 else "/api/tf")[2])
    c = state["camera"]
    cli = cli_render(inputs, tmp_path / "cli.png", "--model", state["model"],
                     "--tf2" if tf2 else "--tf", tf,
                     "--size", "256x256", "--azimuth", c["azimuth"], "--elevation",
                     c["elevation"], "--zoom", c["zoom"])
    b64 = driver.execute_async_script(
        "window.udvr.pngBase64('main').then(arguments[0])")
    assert np.array_equal(png_pixels(base64.b64decode(b64)), cli)
    # What the canvas shows: the PNG's RGB (composited over the background), opaque.
    rgb = driver.execute_script(
        "const c = document.querySelector('figure[data-channel=main] canvas');"
        "return Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data);")
    shown = np.array(rgb, dtype=np.uint8).reshape(cli.shape)
    assert np.array_equal(shown[..., :3], cli[..., :3])
    return state


def main_canvas(driver):
    return driver.find_element("css selector", "figure[data-channel=main] canvas")


def test_load_shows_the_cli_image(page, server, inputs, tmp_path):
    state = assert_page_is_cli(page, server, inputs, tmp_path)
    assert state["camera"] == {"azimuth": "30", "elevation": "20", "zoom": "1"}
    command = page.find_element("id", "command").text
    assert f"--model {state['model']} --tf tf.json --size 256x256 --azimuth 30" in command


def test_drag_orbits(page, server, inputs, tmp_path):
    ActionChains(page).drag_and_drop_by_offset(main_canvas(page), 60, 24).perform()
    wait_idle(page)
    state = assert_page_is_cli(page, server, inputs, tmp_path)
    assert state["camera"]["azimuth"] != "30" and state["camera"]["elevation"] != "20"
    timings = page.execute_script("return window.udvr.state.timings.map(t => t.kind)")
    assert "coarse" in timings  # frames while dragging were coarse, the last one full


def test_wheel_zooms(page, server, inputs, tmp_path):
    ActionChains(page).scroll_from_origin(
        __import__("selenium.webdriver.common.actions.wheel_input", fromlist=["ScrollOrigin"])
        .ScrollOrigin.from_element(main_canvas(page)), 0, -200).perform()
    wait_idle(page)
    state = assert_page_is_cli(page, server, inputs, tmp_path)
    assert float(state["camera"]["zoom"]) > 1


def test_moving_a_tf_point(page, server, inputs, tmp_path):
    before = json.loads(server.get("/api/tf")[2])
    # The highest opacity point of the editor, dragged down.
    x, y = page.execute_script(
        "const e = window.udvr.editor; let best = 0;"
        "e.tf.points.forEach((p, i) => { if (p[1] > e.tf.points[best][1]) best = i; });"
        "const [px, py] = e.toPixel(...e.tf.points[best]);"
        "const r = e.canvas.getBoundingClientRect();"
        "return [px * r.width / e.canvas.width - r.width / 2, py * r.height / e.canvas.height - r.height / 2];")
    canvas = page.find_element("id", "tf-canvas")
    ActionChains(page).move_to_element_with_offset(canvas, int(x), int(y)).click_and_hold() \
        .move_by_offset(0, 30).release().perform()
    wait_idle(page)
    after = json.loads(server.get("/api/tf")[2])
    assert after[0]["Points"] != before[0]["Points"]
    editor = page.execute_script("return window.udvr.editor.tf.points.flat()")
    assert editor == after[0]["Points"]
    assert_page_is_cli(page, server, inputs, tmp_path)


def test_switching_the_model(page, server, inputs, tmp_path):
    picker = Select(page.find_element("id", "model"))
    options = {o.get_attribute("value"): o.is_enabled() for o in picker.options}
    assert {"mean", "uniform", "gaussian", "gmm-ordered", "gmm-mc", "quantile-range",
            "quantile-mean", "quantile-mean-mass", "iqr", "quartile-lower", "quartile-middle",
            "quartile-upper"} <= {k for k, on in options.items() if on}
    picker.select_by_value("quantile-mean")
    wait_idle(page)
    assert assert_page_is_cli(page, server, inputs, tmp_path)["model"] == "quantile-mean"


def test_a_slow_model_comes_in_steps(page, server, inputs, tmp_path):
    """A model whose frame is estimated over the latency goal renders coarse first: here mean's
    estimate is set to 8 s at 512² (2 s at the page's 256²), so the full frame follows one step
    at 128² (0.5 s), and the picker marks it; the last frame is still `udvr render`'s image."""
    page.execute_script(
        "const m = window.udvr.state.info.models.find((m) => m.name === 'mean');"
        "m.estimate_ms = 8000; m.slow = true; window.udvr.state.timings.length = 0;")
    Select(page.find_element("id", "model")).select_by_value("mean")
    wait_idle(page)
    main = page.execute_script(
        "return window.udvr.state.timings.filter((t) => t.channel === 'main').map((t) => t.kind);")
    assert main == ["step", "full"], main
    assert assert_page_is_cli(page, server, inputs, tmp_path)["model"] == "mean"
    page.execute_script(
        "const m = window.udvr.state.info.models.find((m) => m.name === 'mean');"
        "m.estimate_ms = 10; m.slow = false;")


def test_a_slow_model_drags_with_smaller_coarse_frames(page, server, inputs, tmp_path):
    """Coarse frames (dragging) are a quarter of the side, and smaller while the model's estimate
    for them is over the latency goal: mean's estimate set to 200 s at 512² (50 s at the page's
    256², 3.1 s at 64², 0.8 s at 32²), so the drag's coarse frames are 32², the last frame the
    full one, `udvr render`'s image."""
    page.execute_script(
        "const m = window.udvr.state.info.models.find((m) => m.name === 'mean');"
        "m.estimate_ms = 200000; m.slow = true; window.udvr.state.timings.length = 0;")
    ActionChains(page).drag_and_drop_by_offset(main_canvas(page), 40, 16).perform()
    wait_idle(page, 60)
    sizes = page.execute_script(
        "return window.udvr.state.timings.filter((t) => t.channel === 'main')"
        ".map((t) => [t.kind, t.size]);")
    coarse = {size for kind, size in sizes if kind == "coarse"}
    assert coarse == {"32x32"}, sizes
    page.execute_script(
        "const m = window.udvr.state.info.models.find((m) => m.name === 'mean');"
        "m.estimate_ms = 10; m.slow = false; window.udvr.state.timings.length = 0;")
    ActionChains(page).drag_and_drop_by_offset(main_canvas(page), -40, -16).perform()
    wait_idle(page, 60)
    sizes = page.execute_script(
        "return window.udvr.state.timings.filter((t) => t.channel === 'main')"
        ".map((t) => [t.kind, t.size]);")
    assert {size for kind, size in sizes if kind == "coarse"} == {"64x64"}, sizes
    assert sizes[-1] == ["full", "256x256"], sizes


def test_the_page_starts_at_the_librarys_default_size(page, server):
    """The first frames take /api/state's default size (RenderOptions', `udvr render`'s), and
    the size picker shows it: the page holds no size of its own."""
    w, h = (int(n) for n in server.json("/api/state")["defaults"]["size"].split("x"))
    assert page.start_size == ([w, h], str(w)), page.start_size


def test_a_slow_gmm_mc_steps_through_realizations(page, server, inputs, tmp_path):
    """gmm-mc's cost is per realization (drawing one costs about the same at any size): its steps
    keep the image's size and cut the realizations. Its estimate set to 8 s at 512² (2 s at
    256²): one step of 200/4 = 50 realizations at 256², then the full frame (200), which is
    `udvr render`'s image."""
    state = server.json("/api/state")
    assert state["defaults"]["realizations"] == 200
    by = {m["name"]: m for m in state["models"]}
    assert by["gmm-mc"]["realizations"] is True and by["mean"]["realizations"] is False
    page.execute_script(
        "const m = window.udvr.state.info.models.find((m) => m.name === 'gmm-mc');"
        "m.estimate_ms = 8000; m.slow = true; window.udvr.state.timings.length = 0;")
    Select(page.find_element("id", "model")).select_by_value("gmm-mc")
    wait_idle(page, 180)
    main = page.execute_script(
        "return window.udvr.state.timings.filter((t) => t.channel === 'main')"
        ".map((t) => [t.kind, t.size, t.realizations === undefined ? null : t.realizations]);")
    assert main == [["step", "256x256", 50], ["full", "256x256", None]], main
    assert assert_page_is_cli(page, server, inputs, tmp_path)["model"] == "gmm-mc"
    Select(page.find_element("id", "model")).select_by_value("mean")
    wait_idle(page)


def test_a_tf_edit_reads_the_estimates_again(page, server, inputs, tmp_path):
    """The estimates are for a TF: after one is loaded, the page asks the server again and its
    picker follows (mean's estimate, faked as 8 s and slow here, is the server's again)."""
    page.execute_script(
        "const m = window.udvr.state.info.models.find((m) => m.name === 'mean');"
        "m.estimate_ms = 8000; m.slow = true;")
    good = tmp_path / "again.json"
    good.write_text(json.dumps([{"RGBPoints": [-5, 0, 0, 1, 25, 1, 0.5, 0],
                                 "Points": [-5, 0, 0.5, 0, 9, 0, 0.5, 0, 25, 0.6, 0.5, 0]}]))
    page.find_element("id", "tf-load").send_keys(str(good))
    end = time.time() + 10
    while time.time() < end and "again.json" not in page.find_element("id", "status").text:
        time.sleep(0.05)
    wait_idle(page, 60)
    fresh = {m["name"]: m for m in server.json("/api/state")["models"]}
    assert fresh["mean"]["estimate_ms"] is not None  # the page asked for them
    mine = page.execute_script(
        "return window.udvr.state.info.models.map((m) => [m.name, m.estimate_ms, m.slow]);")
    for name, ms, slow in mine:
        assert [ms, slow] == [fresh[name]["estimate_ms"], fresh[name]["slow"]], name
    options = {o.get_attribute("value"): o.text
               for o in Select(page.find_element("id", "model")).options}
    for name, text in options.items():
        assert ("(progressive)" in text) == bool(fresh[name]["slow"]), (name, text)


# The page's fetch, wrapped: /api/state?estimates=1 is held while `hold` (as a server whose probes
# take long; an abort ends it) and its answer passed through `fake`; the main view's full 256²
# frames are held while `holdFull` (still on their way when the estimates come).
WRAP_FETCH = """
const real = window.fetch.bind(window);
const log = window.est = {sent: 0, aborted: 0, answered: 0, inFlight: 0, maxInFlight: 0,
                          hold: true, holdFull: false, fake: null};
const until = (done, signal) => new Promise((resolve, reject) => {
  const tick = () => {
    if (signal && signal.aborted) reject(new DOMException('aborted', 'AbortError'));
    else if (done()) resolve();
    else setTimeout(tick, 5);
  };
  tick();
});
window.fetch = async (url, options = {}) => {
  const u = String(url);
  if (u.startsWith('/api/state') && u.includes('estimates=1')) {
    log.sent++, log.inFlight++, log.maxInFlight = Math.max(log.maxInFlight, log.inFlight);
    try {
      try {
        await until(() => !log.hold, options.signal);
      } catch (e) {
        log.aborted++;
        throw e;
      }
      const r = await real(url, options);
      const j = await r.json();
      if (log.fake) log.fake(j);
      log.answered++;
      return new Response(JSON.stringify(j), {status: 200});
    } finally {
      log.inFlight--;
    }
  }
  const r = await real(url, options);
  if (u.startsWith('/api/render') && u.includes('channel=main') && u.includes('size=256x256') &&
      !u.includes('realizations'))
    await until(() => !log.holdFull);
  return r;
};
"""

EDIT_TF = """
const e = window.udvr.editor; let best = 0;
e.tf.points.forEach((p, i) => { if (p[1] > e.tf.points[best][1]) best = i; });
e.tf.points[best][1] *= 0.9;
e.onChange('commit');
"""


def wait_for(driver, script, timeout=20):
    end = time.time() + timeout
    while time.time() < end:
        if driver.execute_script(script):
            return
        time.sleep(0.02)
    raise AssertionError(f"not so after {timeout} s: {script}; "
                         f"{driver.execute_script('return window.est')}")


def test_tf_edits_supersede_the_estimates_and_redecide_the_steps(server, inputs, tmp_path):
    """After TF edits the page asks for the estimates once the edits pause (debounced), never
    with two requests on their way: a newer edit aborts the older request. The new estimates
    re-mark the picker and re-decide the views' steps: mean, quick with the old TF, is 8 s at
    512² with the new one (faked), so its full frame, asked for with the old estimate and still
    on its way, gives way to a 128² step and then the full frame (`udvr render`'s image)."""
    driver = open_page(server.url)
    try:
        Select(driver.find_element("id", "model")).select_by_value("mean")
        wait_idle(driver)
        driver.execute_script(WRAP_FETCH)
        driver.execute_script(EDIT_TF)
        wait_for(driver, "return window.est.sent === 1")  # the first edit's request, held
        driver.execute_script(EDIT_TF + "window.udvr.state.timings.length = 0;"
                              "window.est.holdFull = true;")
        driver.execute_script(EDIT_TF)
        wait_for(driver, "return window.est.sent === 2")
        time.sleep(0.6)  # twice the debounce: the last two edits asked once
        est = driver.execute_script("return window.est")
        assert (est["sent"], est["aborted"], est["maxInFlight"]) == (2, 1, 1), est
        driver.execute_script(
            "window.est.fake = (j) => { const m = j.models.find((m) => m.name === 'mean');"
            " m.estimate_ms = 8000; m.slow = true; }; window.est.hold = false;")
        wait_for(driver, "return window.est.answered === 1")
        # The step comes while the full frames asked for with the old estimates are held.
        wait_for(driver, "return window.udvr.state.timings.some((t) => t.kind === 'step')")
        driver.execute_script("window.est.holdFull = false;")
        wait_idle(driver)
        main = driver.execute_script(
            "return window.udvr.state.timings.filter((t) => t.channel === 'main')"
            ".map((t) => [t.kind, t.size]);")
        assert main == [["step", "128x128"], ["full", "256x256"]], main
        text = [o.text for o in Select(driver.find_element("id", "model")).options
                if o.get_attribute("value") == "mean"][0]
        assert "about 8.0 s (progressive)" in text, text
        est = driver.execute_script("return window.est")
        assert (est["sent"], est["aborted"], est["maxInFlight"]) == (2, 1, 1), est
        assert_page_is_cli(driver, server, inputs, tmp_path)
    finally:
        driver.quit()


def test_tf2_edits_read_the_estimates_again(tf2_page, inputs, tmp_path):
    """With a 2D TF, an edit in the editor and a loaded widget file each have the page ask for
    the estimates again: its models' estimates (mean's faked as 8 s and slow before each) become
    the server's for the new TF2 (whatever they are under this machine's load)."""
    server, driver = tf2_page

    def fake():
        driver.execute_script(
            "const m = window.udvr.state.info.models.find((m) => m.name === 'mean');"
            "m.estimate_ms = 8000; m.slow = true;")

    def check():
        wait_idle(driver, 60)
        kept = {m["name"]: m for m in server.json("/api/state")["models"]}
        assert kept["mean"]["estimate_ms"] is not None  # asked for this TF2
        mine = driver.execute_script(
            "return window.udvr.state.info.models.map((m) => [m.name, m.estimate_ms, m.slow]);")
        for name, ms, slow in mine:
            assert [ms, slow] == [kept[name]["estimate_ms"], kept[name]["slow"]], name

    fake()
    driver.execute_script("const e = window.udvr.editor2; e.doc.widgets[0].rgba[3] *= 0.5;"
                          "e.onChange('commit');")
    check()
    loaded = tmp_path / "loaded_tf2.json"
    doc = json.loads(TANGLE_TF2.read_text())
    doc["widgets"][0]["rgba"][3] *= 0.25
    loaded.write_text(json.dumps(doc))
    fake()
    driver.find_element("id", "tf2-load").send_keys(str(loaded))
    end = time.time() + 20
    while time.time() < end and "loaded_tf2.json" not in driver.find_element("id", "status").text:
        time.sleep(0.05)
    check()


def test_picker_marks_models_over_the_goal(inputs):
    """With a 2D TF the uniform kernel's 512² frame takes minutes: its option says so."""
    s = Server(inputs.model, "--tf2", TANGLE_TF2)
    driver = None
    try:
        driver = open_page(s.url)
        state = s.json("/api/state")  # the estimates the page asked for, kept
        slow = {m["name"] for m in state["models"] if m["available"] and m["slow"]}
        assert "uniform" in slow
        options = {o.get_attribute("value"): o.text
                   for o in Select(driver.find_element("id", "model")).options}
        for name, text in options.items():
            assert ("(progressive)" in text) == (name in slow), (name, text)
    finally:
        if driver:
            driver.quit()
        s.stop()


def test_quartile_view_shows_three_more_images(page, server, inputs, tmp_path):
    page.find_element("id", "quartiles").click()
    wait_idle(page)
    channels = page.execute_script(
        "return Array.from(document.querySelectorAll('figure.view')).map(f => f.dataset.channel)")
    assert channels == ["main", "quartile-lower", "quartile-middle", "quartile-upper"]
    c = page_state(page)["camera"]
    tf = tmp_path / "tf.json"
    tf.write_bytes(server.get("/api/tf")[2])
    b64 = page.execute_async_script("window.udvr.pngBase64('quartile-upper').then(arguments[0])")
    cli = cli_render(inputs, tmp_path / "q.png", "--model", "quartile-upper", "--tf", tf,
                     "--size", "256x256", "--azimuth", c["azimuth"], "--elevation",
                     c["elevation"], "--zoom", c["zoom"])
    assert np.array_equal(png_pixels(base64.b64decode(b64)), cli)
    page.find_element("id", "quartiles").click()
    wait_idle(page)


def test_click_probe_plots_the_cli_numbers(page, server, inputs, tmp_path):
    canvas = main_canvas(page)
    ActionChains(page).move_to_element(canvas).click().perform()  # the centre: the volume
    end = time.time() + 20
    rows = []
    while time.time() < end and len(rows) < 4:
        rows = page.find_elements("css selector", "#probe-table tr")
        time.sleep(0.05)
    wait_idle(page)
    rows = page.find_elements("css selector", "#probe-table tr")
    assert {r.get_attribute("data-model") for r in rows} >= {
        "quantile-range", "gaussian", "gmm-ordered", "uniform"}
    tf = tmp_path / "tf.json"
    tf.write_bytes(server.get("/api/tf")[2])
    for r in rows:
        shown = json.loads(r.get_attribute("data-json"))
        assert shown == cli_probe(inputs.model, tf, r.get_attribute("data-model"), shown["point"])
    assert "udvr probe" in page.find_element("id", "command").text
    # The plot drew something.
    drawn = page.execute_script(
        "const c = document.getElementById('probe-plot');"
        "return c.getContext('2d').getImageData(0, 0, c.width, c.height).data.some(v => v > 0);")
    assert drawn


def test_tf_file_load_and_a_broken_one(page, server, inputs, tmp_path):
    broken = tmp_path / "broken.json"
    broken.write_text('[{"RGBPoints": [0, 1, 1, 1], "Points": [5, 0.2, 0.5, 0, 1, 0.1, 0.5, 0]}]')
    before = server.get("/api/tf")[2]
    page.find_element("id", "tf-load").send_keys(str(broken))
    end = time.time() + 10
    while time.time() < end and "error" not in page.find_element("id", "status").get_attribute("class"):
        time.sleep(0.05)
    status = page.find_element("id", "status")
    assert "error" in status.get_attribute("class") and "sorted" in status.text
    assert server.get("/api/tf")[2] == before  # refused: the TF is kept
    good = tmp_path / "good.json"
    good.write_text(json.dumps([{"RGBPoints": [-5, 0, 0, 1, 25, 1, 0.5, 0],
                                 "Points": [-5, 0, 0.5, 0, 8, 0, 0.5, 0, 25, 0.7, 0.5, 0]}]))
    page.find_element("id", "tf-load").send_keys(str(good))
    end = time.time() + 10
    while time.time() < end and "good.json" not in page.find_element("id", "status").text:
        time.sleep(0.05)
    wait_idle(page)
    assert json.loads(server.get("/api/tf")[2])[0]["Points"] == [-5, 0, 0.5, 0, 8, 0, 0.5, 0,
                                                                  25, 0.7, 0.5, 0]
    assert_page_is_cli(page, server, inputs, tmp_path)


def test_tf2_editor_add_move_resize_delete(inputs, tmp_path):
    """--tf2 widgets.json: the 2D editor over the joint histogram; a box added, moved and resized
    with the mouse, then deleted: after each, the page's image is `udvr render --tf2` of the
    widget file the server saves."""
    server = Server(inputs.model, "--tf2", ROOT / "data" / "tf2" / "tangle.json")
    driver = None
    try:
        driver = open_page(server.url)
        assert driver.find_element("id", "tf2-panel").is_displayed()
        assert not driver.find_element("id", "tf-panel").is_displayed()
        assert "--tf2 tf2.json --size 256x256" in driver.find_element("id", "command").text
        dark = driver.execute_script(  # the histogram drawn: grey and black pixels
            "const c = document.getElementById('tf2-canvas');"
            "return c.getContext('2d').getImageData(0, 0, c.width, c.height).data"
            ".filter((v, i) => i % 4 === 0 && v < 100).length;")
        assert dark > 100
        assert_page_is_cli(driver, server, inputs, tmp_path, tf2=True)
        driver.find_element("id", "tf2-add-box").click()
        wait_idle(driver)
        added = json.loads(server.get("/api/tf2")[2])["widgets"]
        assert len(added) == 4 and added[3]["type"] == "box"
        canvas = driver.find_element("id", "tf2-canvas")
        x, y = driver.execute_script("return window.udvr.editor2.centreOffset(3)")
        ActionChains(driver).move_to_element_with_offset(canvas, int(x), int(y)).click_and_hold() \
            .move_by_offset(20, -10).move_by_offset(20, -10).release().perform()
        wait_idle(driver)
        moved = json.loads(server.get("/api/tf2")[2])["widgets"][3]
        assert moved["x"][0] > added[3]["x"][0] and moved["y"][0] > added[3]["y"][0]
        assert driver.execute_script("return window.udvr.editor2.doc.widgets[3]") == moved
        timings = driver.execute_script("return window.udvr.state.timings.map(t => t.kind)")
        assert "coarse" in timings  # frames while dragging were coarse, the last one full
        assert_page_is_cli(driver, server, inputs, tmp_path, tf2=True)
        # The top-right corner handle, dragged right: the box widens.
        px, py = driver.execute_script(
            "const e = window.udvr.editor2, w = e.doc.widgets[3];"
            "const [px, py] = e.toPixel(w.x[1], w.y[1]), r = e.canvas.getBoundingClientRect();"
            "return [px * r.width / e.canvas.width - r.width / 2,"
            "        py * r.height / e.canvas.height - r.height / 2];")
        ActionChains(driver).move_to_element_with_offset(canvas, int(px), int(py)) \
            .click_and_hold().move_by_offset(25, 0).release().perform()
        wait_idle(driver)
        resized = json.loads(server.get("/api/tf2")[2])["widgets"][3]
        assert resized["x"][1] > moved["x"][1] and resized["x"][0] == moved["x"][0]
        assert_page_is_cli(driver, server, inputs, tmp_path, tf2=True)
        driver.find_element("id", "tf2-delete").click()
        wait_idle(driver)
        assert len(json.loads(server.get("/api/tf2")[2])["widgets"]) == 3
        assert_page_is_cli(driver, server, inputs, tmp_path, tf2=True)
    finally:
        if driver:
            driver.quit()
        server.stop()


# ---- the 2D TF editor: rotating an ellipse, reshaping a band; the probe with a TF2 ------------
TANGLE_TF2 = ROOT / "data" / "tf2" / "tangle.json"
WIDGET_KEYS = {"box": {"type", "x", "y", "rgba"},
               "triangle": {"type", "apex", "top", "width", "rgba", "falloff"},
               "ellipse": {"type", "center", "sigma", "angle", "cutoff", "rgba"},
               "band": {"type", "points", "half_width", "profile", "rgba"}}


@pytest.fixture
def tf2_page(inputs):
    """A server with --tf2 data/tf2/tangle.json and the page on it, recording what it POSTs."""
    server = Server(inputs.model, "--tf2", TANGLE_TF2)
    driver = None
    try:
        driver = open_page(server.url)
        driver.execute_script(
            "window.posted = []; const f = window.fetch;"
            "window.fetch = (url, o) => { if (o && o.method === 'POST')"
            " window.posted.push([String(url), o.body]); return f(url, o); };")
        yield server, driver
    finally:
        if driver:
            driver.quit()
        server.stop()


def last_posted(driver):
    """The last widget JSON the page POSTed to /api/tf2, checked against docs/formats.md's keys:
    the page's own document, and what the server gives back."""
    url, body = driver.execute_script("return window.posted[window.posted.length - 1]")
    assert url.endswith("/api/tf2")
    doc = json.loads(body)
    assert set(doc) <= {"domain", "resolution", "widgets", "name", "comment"}
    for w in doc["widgets"]:
        assert set(w) <= WIDGET_KEYS[w["type"]] | {"name", "comment"}, w
    assert doc == driver.execute_script("return window.udvr.editor2.doc")
    return doc


def press_drag(driver, element, offset, *moves):
    """Press at `offset` (CSS pixels from the element's centre), move by each of `moves`,
    release."""
    chain = ActionChains(driver).move_to_element_with_offset(element, int(offset[0]),
                                                             int(offset[1])).click_and_hold()
    for dx, dy in moves:
        chain = chain.move_by_offset(dx, dy)
    chain.release().perform()


def type_into(driver, element_id, text):
    """Replace a field's text as a user types it, then leave the field (its change event)."""
    driver.find_element("id", element_id).send_keys(Keys.CONTROL, "a", Keys.NULL, text, Keys.TAB)


def assert_posted_renders_as_cli(driver, server, inputs, tmp_path, doc):
    """The page's image is `udvr render --tf2` of the widget file the page posted."""
    wait_idle(driver)
    (tmp_path / "posted.json").write_text(json.dumps(doc))
    assert json.loads(server.get("/api/tf2")[2]) == doc
    assert_page_is_cli(driver, server, inputs, tmp_path, tf2=True, tf=tmp_path / "posted.json")


def data_point(driver, offset):
    """The 2D editor's data point under `offset` (CSS pixels from its canvas's centre)."""
    return driver.execute_script(
        "const e = window.udvr.editor2, r = e.canvas.getBoundingClientRect();"
        "return e.fromPixel((arguments[0] + r.width / 2) * e.canvas.width / r.width,"
        "                   (arguments[1] + r.height / 2) * e.canvas.height / r.height);",
        *offset)


def test_tf2_editor_rotates_an_ellipse(tf2_page, inputs, tmp_path):
    """The ellipse's round handle turns its sx axis to the pointer (angle in data units); the
    angle field sets it; each time the posted JSON changes only `angle` and the page renders as
    the CLI does with the posted file."""
    server, driver = tf2_page
    canvas = driver.find_element("id", "tf2-canvas")
    before = json.loads(server.get("/api/tf2")[2])["widgets"]
    assert before[1]["type"] == "ellipse" and "angle" not in before[1]
    ActionChains(driver).move_to_element_with_offset(
        canvas, *map(int, driver.execute_script("return window.udvr.editor2.centreOffset(1)"))) \
        .click().perform()
    assert driver.execute_script("return window.udvr.editor2.selected") == 1
    assert driver.find_element("id", "tf2-angle").is_displayed()
    assert not driver.find_element("id", "tf2-hx").is_displayed()
    start = driver.execute_script("return window.udvr.editor2.handleOffset(1, 'rotate')")
    press_drag(driver, canvas, start, (-30, -30), (-30, -30))
    wait_idle(driver)
    doc = last_posted(driver)
    turned = doc["widgets"][1]
    # Where the pointer was let go, in data units: the sx axis points there.
    cx, cy = turned["center"]
    x, y = data_point(driver, (int(start[0]) - 60, int(start[1]) - 60))
    want = np.degrees(np.arctan2(y - cy, x - cx))
    assert 90 < turned["angle"] < 180 and abs(turned["angle"] - want) < 1.5
    assert {k: v for k, v in turned.items() if k != "angle"} == before[1]
    assert [w for k, w in enumerate(doc["widgets"]) if k != 1] == before[:1] + before[2:]
    assert float(driver.find_element("id", "tf2-angle").get_attribute("value")) == turned["angle"]
    assert_posted_renders_as_cli(driver, server, inputs, tmp_path, doc)
    type_into(driver, "tf2-angle", "-30")
    wait_idle(driver)
    doc = last_posted(driver)
    assert doc["widgets"][1]["angle"] == -30 and doc["widgets"][1]["center"] == [cx, cy]
    assert_posted_renders_as_cli(driver, server, inputs, tmp_path, doc)


def test_tf2_editor_reshapes_a_band(tf2_page, inputs, tmp_path):
    """+ band adds a three-point band; dragging a point's handle moves that point only; the half
    width fields set `half_width`; each posted file renders as the page shows."""
    server, driver = tf2_page
    canvas = driver.find_element("id", "tf2-canvas")
    driver.find_element("id", "tf2-add-band").click()
    wait_idle(driver)
    added = last_posted(driver)["widgets"][3]
    assert added["type"] == "band" and len(added["points"]) == 3
    assert driver.find_element("id", "tf2-hx").is_displayed()
    assert not driver.find_element("id", "tf2-angle").is_displayed()
    start = driver.execute_script("return window.udvr.editor2.handleOffset(3, 'p1')")
    press_drag(driver, canvas, start, (15, -10), (15, -10))
    wait_idle(driver)
    doc = last_posted(driver)
    band = doc["widgets"][3]
    x, y = data_point(driver, (int(start[0]) + 30, int(start[1]) - 20))
    assert band["points"][1] == pytest.approx([x, y], abs=0.25)  # within a pixel
    assert all(band["points"][1][k] > added["points"][1][k] for k in (0, 1))
    assert band["points"][0] == added["points"][0] and band["points"][2] == added["points"][2]
    assert band["half_width"] == added["half_width"] and band["rgba"] == added["rgba"]
    assert_posted_renders_as_cli(driver, server, inputs, tmp_path, doc)
    type_into(driver, "tf2-hx", "2.5")
    type_into(driver, "tf2-hy", "7")
    wait_idle(driver)
    doc = last_posted(driver)
    assert doc["widgets"][3]["half_width"] == [2.5, 7]
    assert doc["widgets"][3]["points"] == band["points"]
    type_into(driver, "tf2-hy", "0")  # not > 0: not taken; the field shows the widget's again
    assert driver.execute_script("return window.udvr.editor2.doc.widgets[3].half_width") == [2.5, 7]
    assert driver.find_element("id", "tf2-hy").get_attribute("value") == "7"
    assert_posted_renders_as_cli(driver, server, inputs, tmp_path, doc)


BIVARIATE_TF2 = {"domain": [-7, 35, -7, 35], "widgets": [
    {"type": "band", "points": [[-7, -7], [35, 35]], "half_width": [1.5, 1.5],
     "rgba": [0.9, 0.5, 0.1, 0.5]}]}


@pytest.mark.parametrize("second", [False, True], ids=["gradient", "second"])
def test_tf2_probe_plot_is_the_cli_probe(inputs, tmp_path, second):
    """With --tf2 the probe's table is `udvr probe --json --tf2`'s, and the plot's dashed opacity
    is the TF2 along the value at the probed model's mean gradient magnitude there (with
    --second: field 2's mean): the raster `udvr tf2 -o` writes, bilinear."""
    if second:
        (tmp_path / "start.json").write_text(json.dumps(BIVARIATE_TF2))
        args = ["--tf2", tmp_path / "start.json", "--second", inputs.truth]
    else:
        args = ["--tf2", TANGLE_TF2]
    server = Server(inputs.model, *args)
    driver = None
    try:
        driver = open_page(server.url)
        check_tf2_probe(server, driver, inputs, tmp_path, second)
    finally:
        if driver:
            driver.quit()
        server.stop()


def check_tf2_probe(server, driver, inputs, tmp_path, second):
    """A click probe on the main view, checked against `udvr probe --json --tf2` and the raster."""
    ActionChains(driver).move_to_element(main_canvas(driver)).click().perform()
    end = time.time() + 20
    while time.time() < end and not driver.execute_script("return !!window.udvr.state.probe"):
        time.sleep(0.05)
    wait_idle(driver)
    (tmp_path / "tf2.json").write_bytes(server.get("/api/tf2")[2])
    rows = driver.find_elements("css selector", "#probe-table tr")
    # The plotted models that classify with this 2D TF (gmm-ordered and uniform have no value x
    # gradient kernel; a plain-field second has no quantiles).
    available = {m["name"] for m in server.json("/api/state")["models"] if m["available"]}
    plotted = {"quantile-range", "gaussian", "gmm-ordered", "uniform"} & available
    assert plotted >= ({"gaussian"} if second else {"quantile-range", "gaussian"})
    assert {r.get_attribute("data-model") for r in rows} >= plotted
    cli = {}
    for r in rows:
        shown = json.loads(r.get_attribute("data-json"))
        name = r.get_attribute("data-model")
        cli[name] = cli_probe(inputs.model, tmp_path / "tf2.json", name, shown["point"], "--tf2",
                              *(["--second", inputs.truth] if second else []))
        assert shown == cli[name]
    probe = driver.execute_script("return window.udvr.state.probe")
    g = cli[probe["model"]]["gradient_magnitude"]
    if second:  # field 2's mean at the point
        assert g["mean"] == cli[probe["model"]]["second"]["mean"]
    row = probe["tf2Row"]
    assert row["y"] == g["mean"] and len(row["x"]) == 401
    raster = tf2_raster(tmp_path / "tf2.json", tmp_path / "tf2.npy")
    domain = json.loads((tmp_path / "tf2.json").read_text())["domain"]
    want = [tf2_at(raster, domain, x, g["mean"]) for x in row["x"]]
    assert np.allclose(row["rgba"], want, rtol=0, atol=1e-7)  # a float32 raster's precision
    assert max(a for *_, a in row["rgba"]) > 0
    note = driver.find_element("id", "probe-tf2").text
    y_name = "field 1 at field 2" if second else "the value at gradient magnitude"
    assert f"{y_name} {row['y']!r}" in note and probe["model"] in note
    command = driver.find_element("id", "command").text
    assert "udvr probe" in command and "--tf2 tf2.json" in command
