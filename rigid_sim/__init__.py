# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
