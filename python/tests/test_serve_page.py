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
from serve_util import Server, cli_probe, cli_render, make_inputs, png_pixels

CHROMIUM = shutil.which("chromium")
DRIVER = shutil.which("chromedriver")
try:
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.action_chains import ActionChains
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
    raise AssertionError(f"page not idle after {timeout} s; status: {status!r}")


def page_state(driver):
    return driver.execute_script(
        "const s = window.udvr.state; return {model: s.model, camera: window.udvr.cameraParams()};")


def assert_page_is_cli(driver, server, inputs, tmp_path, tf2=False):
    """The main view's PNG and canvas pixels equal `udvr render` of the page's state (its TF, or
    with tf2 its 2D TF, as saved from the server)."""
    state = page_state(driver)
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
