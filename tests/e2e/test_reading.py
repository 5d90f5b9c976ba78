"""Reading the app (issue 15): an unknown address shows the app's "Page not found" with a
404, and every view names its browser tab."""

from __future__ import annotations

import re

from playwright.sync_api import Page, expect

from tests.api.server import Server


def test_unknown_addresses_and_page_titles(page: Page) -> None:
    answer = page.goto("/no/such/page")
    assert answer is not None and answer.status == 404
    expect(page.get_by_role("heading", name="Page not found")).to_be_visible()
    assert page.title() == "Page not found · E-Lab"
    page.goto("/plants/flexible_link/nonsense")  # under a real path: the app's router says it
    expect(page.get_by_role("heading", name="Page not found")).to_be_visible()
    page.goto("/plants/flexible_link/identification")
    expect(page.get_by_role("heading", level=1)).to_contain_text("identification")
    assert page.title().endswith(": identification · E-Lab") and page.title() != "E-Lab"
    page.goto("/runs")
    expect(page.get_by_role("heading", name="Runs", level=1)).to_be_visible()
    assert page.title() == "Runs · E-Lab"


def test_plant_pages_speak_to_students_and_promise_no_rig(page: Page) -> None:
    """Issue 15: "seed §4.1.1"-style jargon on the plant pages, and a "real rig" on the
    home card before one is connected. The source is cited as a source ([1], listed)."""
    page.goto("/")
    expect(page.get_by_role("heading", level=1)).to_be_visible()
    assert "real rig" not in page.locator("main").inner_text().lower()
    for plant in ("flexible_link", "double_pendulum", "belt_conveyor"):
        page.goto(f"/plants/{plant}")
        expect(page.get_by_role("heading", name="Source")).to_be_visible()
        text = page.locator("main").inner_text()
        assert "seed" not in text.lower(), plant
        assert "[1]" in text


def test_the_home_page_loads_no_plotly_and_pages_fit_a_phone(page: Page, server: Server) -> None:
    """Issue 15 (item 8): every page loaded one 5 MB script (plotly and KaTeX), about 5 s
    per cold page here; the home page now loads neither, the views load with their first
    visit. At 390 px width no page scrolls sideways, also with 20 runs listed (issue 23: the
    runs table, 760 px wide, made the home and runs pages scroll; it scrolls in its box)."""
    with server.client() as c:  # 20 recent runs (issue 27), of every plant
        for i in range(20):
            plant = ("belt_conveyor", "double_pendulum", "flexible_link")[i % 3]
            body = {"plant": plant, "pace": "fast", "duration": 0.2}
            assert c.post("/runs", json=body).status_code == 201
    scripts: list[str] = []
    page.on("request", lambda r: scripts.append(r.url) if r.resource_type == "script" else None)
    page.goto("/")
    expect(page.get_by_role("heading", level=1)).to_be_visible()
    page.wait_for_load_state("networkidle")
    assert scripts and not [u for u in scripts if "/plot-" in u or "/markdown-" in u], scripts
    page.goto("/plants/flexible_link/analysis")
    expect(page.locator(".js-plotly-plot, [data-testid]").first).to_be_attached()
    assert any("/plot-" in u for u in scripts)  # the view brought the plot with it
    page.set_viewport_size({"width": 390, "height": 800})
    shown = {
        "/": "table.runs",
        "/plants/flexible_link": ".description",
        "/plants/flexible_link/analysis": ".js-plotly-plot",
        "/runs": "table.runs",
    }
    for path, content in shown.items():
        page.goto(path)
        expect(page.locator("header.page h1")).to_be_visible()
        expect(page.locator(content).first).to_be_visible(timeout=30_000)
        width = page.evaluate("document.documentElement.scrollWidth")
        assert width <= 390, (path, width)


def test_the_pendulums_outputs_get_axes_of_their_own_size(page: Page) -> None:
    """Issue 15: live, β₂ (about 180°) shared an axis with α and β₁ (about a degree) and
    flattened them. β₂ now has its own axes, and β₁ (issue 27); the control has the last."""
    page.goto("/plants/double_pendulum/analysis")
    page.get_by_role("button", name="Start").first.click()
    plot = page.locator(".run-panel .js-plotly-plot").first
    expect(plot).to_be_attached(timeout=20_000)
    page.wait_for_function(
        "() => (document.querySelector('.run-panel .js-plotly-plot')?.data ?? [])"
        ".some((t) => t.x && t.x.length > 10)",
        timeout=20_000,
    )
    axes = plot.evaluate(
        "(div) => Object.fromEntries(div.data.map((t) => [t.name, t.yaxis || 'y']))"
    )
    beta2 = [a for name, a in axes.items() if "β₂" in name or "beta2" in name.lower()]
    others = [a for name, a in axes.items() if "β₁" in name or "α" in name]
    assert beta2 and others and set(beta2).isdisjoint(others), axes
    # issue 27: β₁'s half degree has its own axes too (it was flat beside α's 45°), and
    # the titles use the legend's symbols
    beta1 = [a for name, a in axes.items() if "β₁" in name]
    alpha = [a for name, a in axes.items() if "α" in name]
    assert beta1 and alpha and set(beta1).isdisjoint(alpha), axes
    assert axes.get("control u") == "y4", axes
    titles = plot.evaluate(
        "(div) => Object.entries(div._fullLayout).filter(([k]) => k.startsWith('yaxis'))"
        ".map(([, a]) => a.title?.text ?? '')"
    )
    assert {"α (°)", "β₁ (°)", "β₂ (°)", "u (V)"} <= set(titles), titles
    assert not [t for t in titles if "beta" in t or "alpha" in t], titles


def test_transfer_functions_say_what_they_map(page: Page) -> None:
    """Issue 15: the analysis page's transfer functions were not labelled (θ/u? α/u?).
    They are typeset when they come near the screen (issue 28: KaTeX is not loaded for a
    page whose formulas are not looked at)."""
    scripts: list[str] = []
    page.on("request", lambda r: scripts.append(r.url) if r.resource_type == "script" else None)
    page.goto("/plants/flexible_link/analysis")
    first = page.get_by_test_id("tf-theta")
    expect(first).to_be_visible(timeout=20_000)
    page.wait_for_load_state("networkidle")
    below = page.evaluate(
        "(el) => el.getBoundingClientRect().top > 2 * window.innerHeight", first.element_handle()
    )
    typesetter = [u for u in scripts if "/assets/markdown-" in u]
    if below:  # more than a screen below the fold: not typeset, KaTeX not loaded
        assert not typesetter, typesetter
        expect(first.locator(".katex")).to_have_count(0)
    for name, symbol in (("theta", "θ"), ("alpha", "α")):
        tf = page.get_by_test_id(f"tf-{name}")
        tf.scroll_into_view_if_needed()
        expect(tf.locator(".katex").first).to_be_visible()
        annotation = tf.locator("annotation").first.text_content() or ""
        assert annotation.startswith(f"\\frac{{\\{name}(s)}}{{u(s)}} = "), annotation
        assert symbol in tf.inner_text()


def test_help_inside_the_app_from_an_experiment_page_to_a_term(page: Page) -> None:
    """Issue 27, item 5: each experiment page says what the student will learn and links
    its help; the help renders the docs, its links stay in the app, and a search finds a
    term across the pages."""
    page.goto("/plants/flexible_link/identification")
    learn = page.get_by_test_id("learn")
    expect(learn).to_contain_text("You will excite the plant")
    learn.get_by_role("link", name="Help: the methods and the verdicts").click()
    expect(page).to_have_url(re.compile(r"/help/identification$"))
    expect(page.get_by_role("heading", name="System identification", level=1)).to_be_visible()
    assert page.title() == "System identification · E-Lab"
    # a link to another page of the help opens it in the app (no reload of the app)
    page.evaluate("() => { window.__same = true; }")
    page.get_by_role("link", name="Help", exact=True).first.click()
    expect(page).to_have_url(re.compile(r"/help$"))
    search = page.get_by_label("search the help")
    search.fill("PRBS")
    hits = page.get_by_test_id("help-results").get_by_role("link")
    expect(hits.first).to_be_visible()
    assert any(t.startswith("Glossary") for t in hits.all_inner_texts())
    page.get_by_test_id("help-results").get_by_role(
        "link", name=re.compile("^Glossary")
    ).first.click()
    expect(page).to_have_url(re.compile(r"/help/glossary#glossary$"))
    expect(page.locator("article.help-page")).to_contain_text("pseudo-random binary sequence")
    assert page.evaluate("() => window.__same") is True  # the router's, not a page load
    search_nothing = "no-such-term-anywhere"
    page.goto("/help")
    page.get_by_label("search the help").fill(search_nothing)
    expect(page.get_by_test_id("help-results")).to_contain_text("Nothing in the help says")
