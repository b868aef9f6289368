// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/tracker_choice.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>

namespace imm::evaluation {

std::string verdict_against_baseline(const RankedFilter& filter) {
  if (filter.baseline) return "—";
  const std::array<Difference, 2> differences{filter.versus_baseline_p, filter.versus_baseline_v};
  return std::string(verdict(differences));
}

std::string inconsistency_finding(const RankedFilter& filter) {
  if (filter.baseline || filter.classical || filter.consistency == "consistent" ||
      verdict_against_baseline(filter) != "beats") {
    return "";
  }
  char numbers[96];
  // Without truth (plot criteria) the consistency is the NIS's.
  std::snprintf(numbers, sizeof numbers, "%s %.2f, %.1f %% of the scans inside",
                filter.criteria[0] == "ζ_p" ? "position NEES" : "NIS", filter.position_nees,
                100.0 * filter.scans_inside);
  return filter.name + " beats the classical bar but is " + filter.consistency + " (" + numbers +
         " the 95 % bounds): its covariance does not match its " +
         (filter.criteria[0] == "ζ_p" ? "errors" : "innovations");
}

std::string consistency_hold(const RankedFilter& filter, const RankedFilter& bar) {
  const bool truth = filter.criteria[0] == "ζ_p";
  struct Share {
    const char* name;
    double own, bar;
    long scans;
  };
  const std::array<Share, 2> shares{
      Share{truth ? "position NEES" : "NIS", filter.scans_inside, bar.scans_inside, filter.scans},
      Share{"NIS", filter.nis_inside, bar.nis_inside, filter.nis_scans}};
  std::string text;
  for (std::size_t i = 0; i < (truth ? 2U : 1U); ++i) {
    const Share& s = shares[i];
    const double required = std::min(kConsistentShare, s.bar);
    const double uncertainty =
        s.scans > 0 ? 1.96 * std::sqrt(required * (1.0 - required) / static_cast<double>(s.scans))
                    : 0.0;
    if (!(s.own < required - uncertainty)) continue;
    char numbers[160];
    std::snprintf(numbers, sizeof numbers,
                  "%s inside its 95 %% bounds on %.1f %% of the scans, below the %.1f %% %s",
                  s.name, 100.0 * s.own, 100.0 * required,
                  s.bar < kConsistentShare ? "the bar reaches" : "of a consistent filter");
    char beyond[96] = "";
    if (s.scans > 0) {
      std::snprintf(beyond, sizeof beyond, " beyond the uncertainty of %ld scans (%.1f %%)",
                    s.scans, 100.0 * uncertainty);
    }
    text += (text.empty() ? "" : "; ") + std::string(numbers) + beyond;
  }
  return text.empty() ? text : "consistency: " + text;
}

TrackerChoice choose_tracker(std::span<const RankedFilter> filters) {
  const auto baselines =
      std::count_if(filters.begin(), filters.end(), [](const auto& f) { return f.baseline; });
  if (baselines != 1) {
    throw std::invalid_argument("choose_tracker: exactly one filter must be the baseline, not " +
                                std::to_string(baselines));
  }
  TrackerChoice choice;
  choice.order.resize(filters.size());
  std::iota(choice.order.begin(), choice.order.end(), std::size_t{0});
  const auto score = [&](std::size_t i) {
    const RankedFilter& f = filters[i];
    return std::isnan(f.score) ? f.zeta_p + f.zeta_v : f.score;
  };
  std::stable_sort(choice.order.begin(), choice.order.end(),
                   [&](std::size_t a, std::size_t b) { return score(a) < score(b); });

  const auto baseline = static_cast<std::size_t>(
      std::find_if(filters.begin(), filters.end(), [](const auto& f) { return f.baseline; }) -
      filters.begin());
  choice.winner = baseline;
  std::vector<std::string> beaten_by, not_earned, held_out;
  choice.held.resize(filters.size());
  for (std::size_t i : choice.order) {
    if (i == baseline || filters[i].classical) continue;
    const std::string v = verdict_against_baseline(filters[i]);
    std::string& hold = choice.held[i];
    hold = filters[i].held_out.empty() ? consistency_hold(filters[i], filters[baseline])
                                       : "own gates: " + filters[i].held_out;
    if (!hold.empty()) {
      std::string text = filters[i].name;
      text += " " + v;
      text += " it but is held out (" + hold;
      text += ")";
      held_out.push_back(std::move(text));
    } else if (v == "beats") {
      if (choice.winner == baseline) choice.winner = i;
      beaten_by.push_back(filters[i].name);
    } else {
      not_earned.push_back(filters[i].name + " " + v + " it (" + filters[i].criteria[0] + " " +
                           filters[i].versus_baseline_p.text() + ", " + filters[i].criteria[1] +
                           " " + filters[i].versus_baseline_v.text() + ")");
    }
  }
  const auto joined = [](const std::vector<std::string>& parts) {
    std::string text;
    for (const auto& p : parts) text += (text.empty() ? "" : "; ") + p;
    return text;
  };
  const RankedFilter& w = filters[choice.winner];
  if (choice.winner == baseline) {
    choice.reason = std::string(held_out.empty() ? "no" : "no eligible") +
                    " learned model beats the classical bar beyond the 95 % interval" +
                    (not_earned.empty() ? std::string() : " (" + joined(not_earned) + ")") +
                    (held_out.empty() ? std::string() : " (" + joined(held_out) + ")") +
                    ", so the bar " + w.name + " is the regime's tracker";
  } else {
    choice.reason =
        w.name + " beats the classical bar (" + w.criteria[0] + " " + w.versus_baseline_p.text() +
        ", " + w.criteria[1] + " " + w.versus_baseline_v.text() + ")" +
        (beaten_by.size() > 1
             ? " and has the lowest " +
                   (std::isnan(w.score) ? w.criteria[0] + " + " + w.criteria[1] : w.criteria[0]) +
                   " of the " + std::to_string(beaten_by.size()) + " learned models that do"
             : std::string());
  }
  return choice;
}

}  // namespace imm::evaluation
