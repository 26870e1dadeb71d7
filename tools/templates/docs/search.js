// Search box of the Ferrolink dictionary site.
//
// The index is the global array FERROLINK_SEARCH_INDEX of {name, kind, url, text} that
// search-index.js defines; it is a script rather than a JSON file so that search works when the
// site is opened from file://, where fetch() is not allowed. Without JavaScript the box stays
// hidden and every page still reads in full.
(function () {
  "use strict";

  var MAX_RESULTS = 60;
  // Among equally good matches, the kinds people look for most come first.
  var KIND_RANK = {
    "message": 0, "enum": 1, "bitmask": 1, "entry": 2, "field": 3, "variable": 3,
    "MAVLink file": 4, "ModRob-1 module": 4, "robot": 4, "TosNet ring": 4,
    "module instance": 5, "network": 5, "area": 5, "node": 5, "register": 6
  };

  function init() {
    var form = document.querySelector("form.search");
    var input = document.getElementById("search");
    var list = document.getElementById("search-results");
    var index = window.FERROLINK_SEARCH_INDEX;
    if (!form || !input || !list || !Array.isArray(index)) {
      return;
    }
    var items = index.map(function (it) {
      var name = String(it.name);
      var lower = name.toLowerCase();
      var cut = Math.max(lower.lastIndexOf("."), lower.lastIndexOf("/"));
      return {
        item: it,
        name: lower,
        tail: cut >= 0 ? lower.slice(cut + 1) : lower,
        text: String(it.text || "").toLowerCase(),
        rank: KIND_RANK.hasOwnProperty(it.kind) ? KIND_RANK[it.kind] : 7
      };
    });
    var active = -1;

    form.hidden = false;
    form.addEventListener("submit", function (ev) {
      ev.preventDefault();
      var links = list.querySelectorAll("a");
      var link = links[active >= 0 ? active : 0];
      if (link) {
        link.click();
      }
    });

    // Lower is better; null when `words` do not all occur.
    function score(entry, words) {
      var total = 0;
      for (var i = 0; i < words.length; i++) {
        var w = words[i];
        var s;
        if (entry.name === w || entry.tail === w) {
          s = 0;
        } else if (entry.name.indexOf(w) === 0 || entry.tail.indexOf(w) === 0) {
          s = 1;
        } else if (entry.name.indexOf("_" + w) >= 0 || entry.name.indexOf("." + w) >= 0) {
          s = 2;
        } else if (entry.name.indexOf(w) >= 0) {
          s = 3;
        } else if (entry.text.indexOf(w) >= 0) {
          s = 6;
        } else {
          return null;
        }
        total += s;
      }
      return total;
    }

    function search(query) {
      var words = query.toLowerCase().split(/\s+/).filter(Boolean);
      if (words.length === 0) {
        return [];
      }
      var hits = [];
      for (var i = 0; i < items.length; i++) {
        var s = score(items[i], words);
        if (s !== null) {
          hits.push({ score: s, entry: items[i] });
        }
      }
      hits.sort(function (a, b) {
        return a.score - b.score ||
          a.entry.rank - b.entry.rank ||
          a.entry.name.length - b.entry.name.length ||
          (a.entry.name < b.entry.name ? -1 : a.entry.name > b.entry.name ? 1 : 0);
      });
      return hits;
    }

    function span(cls, text) {
      var el = document.createElement("span");
      el.className = cls;
      el.textContent = text;
      return el;
    }

    function setActive(i) {
      var links = list.querySelectorAll("a");
      if (links.length === 0) {
        active = -1;
        return;
      }
      active = (i + links.length) % links.length;
      for (var k = 0; k < links.length; k++) {
        links[k].classList.toggle("active", k === active);
        links[k].setAttribute("aria-selected", k === active ? "true" : "false");
      }
      links[active].scrollIntoView({ block: "nearest" });
    }

    function render() {
      var query = input.value.trim();
      list.textContent = "";
      active = -1;
      if (!query) {
        list.hidden = true;
        return;
      }
      var hits = search(query);
      if (hits.length === 0) {
        var none = document.createElement("li");
        none.className = "r-none";
        none.textContent = "Nothing matches \u201c" + query + "\u201d.";
        list.appendChild(none);
      }
      for (var i = 0; i < hits.length && i < MAX_RESULTS; i++) {
        var it = hits[i].entry.item;
        var li = document.createElement("li");
        var a = document.createElement("a");
        a.href = it.url;
        a.setAttribute("role", "option");
        a.appendChild(span("r-kind", it.kind));
        a.appendChild(span("r-name", it.name));
        a.appendChild(span("r-text", it.text || ""));
        li.appendChild(a);
        list.appendChild(li);
      }
      if (hits.length > MAX_RESULTS) {
        var more = document.createElement("li");
        more.className = "r-none";
        more.textContent = (hits.length - MAX_RESULTS) + " more; type more to narrow the search.";
        list.appendChild(more);
      }
      list.hidden = false;
    }

    input.addEventListener("input", render);
    input.addEventListener("focus", function () {
      if (input.value.trim()) {
        render();
      }
    });
    input.addEventListener("keydown", function (ev) {
      if (ev.key === "ArrowDown") {
        ev.preventDefault();
        setActive(active + 1);
      } else if (ev.key === "ArrowUp") {
        ev.preventDefault();
        setActive(active - 1);
      } else if (ev.key === "Escape") {
        input.value = "";
        list.hidden = true;
        input.blur();
      }
    });
    list.addEventListener("click", function (ev) {
      if (ev.target.closest && ev.target.closest("a")) {
        list.hidden = true;
      }
    });
    document.addEventListener("click", function (ev) {
      if (!form.contains(ev.target)) {
        list.hidden = true;
      }
    });
    document.addEventListener("keydown", function (ev) {
      var t = ev.target;
      var typing = t && (t.tagName === "INPUT" || t.tagName === "TEXTAREA" || t.isContentEditable);
      if (ev.key === "/" && !typing && !ev.ctrlKey && !ev.metaKey && !ev.altKey) {
        ev.preventDefault();
        input.focus();
        input.select();
      }
    });
  }

  if (document.readyState === "loading") {
    document.addEventListener("DOMContentLoaded", init);
  } else {
    init();
  }
})();
