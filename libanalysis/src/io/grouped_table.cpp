// A CSV table's rows split into groups (io/grouped_table.hpp).
#include "shearzone/io/grouped_table.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/csv.hpp"

namespace shearzone::io {

std::string unit_of_column(const std::string& column) {
  const auto u = column.find('_');
  return u == std::string::npos ? "" : column.substr(u + 1);
}

GroupedData read_grouped(const std::filesystem::path& input, const std::string& x_column,
                         const std::string& y_column, const std::string& sigma_column,
                         const std::string& group_column, double group_rtol) {
  const io::CsvTable t = read_csv(input);
  const std::string src = input.string();
  const std::size_t cx = t.column_index(x_column), cy = t.column_index(y_column);
  const bool has_sigma = !sigma_column.empty();
  const std::size_t cs = has_sigma ? t.column_index(sigma_column) : 0;
  const bool has_group = !group_column.empty();
  const std::size_t cg = has_group ? t.column_index(group_column) : 0;
  // A status column (`status` of our fit tables, `rc_status` of widths.csv): rows
  // that are not `ok` are skipped and counted.
  const char* status_col = t.has_column("status") ? "status" : "rc_status";
  const bool has_status = t.has_column(status_col);
  const std::size_t cst = has_status ? t.column_index(status_col) : 0;
  if (t.num_rows() == 0)
    throw InputError(fmt::format("{}:{}: the table has no data rows after the header", src,
                                 t.header_line));

  GroupedData g;
  g.x_unit = unit_of_column(x_column);
  g.y_unit = unit_of_column(y_column);
  struct Row {
    std::string key;
    double gv;
    double x, y, s;
  };
  std::vector<Row> rows;
  bool numeric_groups = true;
  for (std::size_t r = 0; r < t.num_rows(); ++r) {
    if (has_status && t.rows[r][cst] != "ok") {
      ++g.skipped_rows;
      continue;
    }
    Row row;
    row.x = t.number(r, cx);
    row.y = t.number(r, cy);
    row.s = 1.0;
    if (has_sigma) {
      row.s = t.number(r, cs);
      if (!(row.s > 0))
        throw InputError(fmt::format("{}:{}: column \"{}\": {} is not a positive uncertainty",
                                     src, t.row_lines[r], sigma_column, t.rows[r][cs]));
    }
    row.key = has_group ? t.rows[r][cg] : "all";
    row.gv = std::nan("");
    if (has_group) {
      double v = 0;
      if (parse_number(row.key, t.decimal_comma, v) && std::isfinite(v)) row.gv = v;
      else numeric_groups = false;
      if (row.key.empty())
        throw InputError(fmt::format("{}:{}: column \"{}\": empty group value", src,
                                     t.row_lines[r], group_column));
    }
    rows.push_back(row);
  }
  if (rows.empty())
    throw InputError(fmt::format("{}:{}: no row has status \"ok\"", src, t.header_line));

  // Group ids: numeric values clustered within the relative tolerance (sorted), or
  // text in order of first appearance.
  std::vector<std::size_t> gid(rows.size());
  if (has_group && numeric_groups) {
    std::vector<double> vals;
    for (const auto& r : rows) vals.push_back(r.gv);
    std::sort(vals.begin(), vals.end());
    vals.erase(std::unique(vals.begin(), vals.end()), vals.end());
    std::vector<double> firsts;  // first (smallest) value of each cluster
    std::map<double, std::size_t> cluster_of;
    for (double v : vals) {
      if (firsts.empty() ||
          std::fabs(v - firsts.back()) > group_rtol * std::max(std::fabs(v), std::fabs(firsts.back())))
        firsts.push_back(v);
      cluster_of[v] = firsts.size() - 1;
    }
    std::vector<double> sum(firsts.size(), 0.0);
    std::vector<std::size_t> cnt(firsts.size(), 0);
    for (std::size_t i = 0; i < rows.size(); ++i) {
      gid[i] = cluster_of[rows[i].gv];
      sum[gid[i]] += rows[i].gv;
      ++cnt[gid[i]];
    }
    for (std::size_t c = 0; c < firsts.size(); ++c) {
      const double mean = sum[c] / static_cast<double>(cnt[c]);
      g.group_values.push_back(mean);
      // Label: the mean to 12 significant digits (0.05, not the 0.05000000000000001
      // that summing three 0.05 gives); the value itself stays exact.
      double label = mean;
      parse_number(fmt::format("{:.12g}", mean), false, label);
      g.labels.push_back(format_number(label));
    }
  } else {
    std::map<std::string, std::size_t> index;
    for (std::size_t i = 0; i < rows.size(); ++i) {
      auto it = index.find(rows[i].key);
      if (it == index.end()) {
        it = index.emplace(rows[i].key, g.labels.size()).first;
        g.labels.push_back(rows[i].key);
        g.group_values.push_back(std::nan(""));
      }
      gid[i] = it->second;
    }
  }
  const std::size_t ng = g.labels.size();
  g.x.resize(ng);
  g.y.resize(ng);
  g.sigma.resize(ng);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    g.x[gid[i]].push_back(rows[i].x);
    g.y[gid[i]].push_back(rows[i].y);
    if (has_sigma) g.sigma[gid[i]].push_back(rows[i].s);
  }
  return g;
}

}  // namespace shearzone::io
