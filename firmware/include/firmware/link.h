/*
 * The telemetry link: estimates, raw samples and health go out as frames of the
 * protocol in docs/reference/telemetry-protocol.md over a byte stream; commands come in, are
 * validated, applied to the application and answered with an ack or a nack.
 * Malformed input is counted by the decoder and reported in health frames.
 *
 * Use: tof_link_init(), put tof_link_output_ops with the link as the platform's
 * output, and either hand tof_app_main() the service {&tof_link_service_ops, &link}
 * or call tof_link_bind() after tof_app_init() and tof_link_poll() once per
 * main-loop iteration. The link sits above the application: it reads and commands
 * it only through the functions app.h declares for that, never its fields.
 */
#ifndef FIRMWARE_LINK_H
#define FIRMWARE_LINK_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/app.h"
#include "firmware/cal_age.h"
#include "firmware/link_storage.h"
#include "firmware/record.h"
#include "firmware/rezero.h"
#include "firmware/settings.h"
#include "hal/hal_serial.h"
#include "telemetry/tlm_frame.h"

/* Received bytes handled per poll: read TOF_LINK_RX_PER_POLL at a time (a buffer on the
 * stack), at most TOF_LINK_RX_CHUNKS times: bounds the time tof_link_poll() takes, and
 * drains a board's whole receive buffer (256 bytes, boards/stm32/stm32_usart.h) in one poll. */
#define TOF_LINK_RX_PER_POLL 64u
#define TOF_LINK_RX_CHUNKS   8u

/* The largest command payload (set-process-noise, docs/reference/telemetry-protocol.md). */
#define TOF_LINK_COMMAND_MAX 9u

/* Health frames at most once per TOF_LINK_HEALTH_PERIOD_US (after the first window's
 * estimates at the earliest): a window shorter than that sends none of its own, so the
 * 155-byte frame costs at most 155 B/s of the link (docs/reference/telemetry-protocol.md, "Link
 * budget"). */
#define TOF_LINK_HEALTH_PERIOD_US 1000000u

struct tof_link {
    struct tof_app *app; /* set by tof_link_bind(), once the app exists; used only
                            through app.h's functions */
    struct hal_serial serial;
    struct tlm_decoder decoder;
    uint8_t seq;               /* sequence number of the next frame sent */
    uint32_t tx_frames;        /* frames handed to the serial port whole */
    uint32_t tx_dropped;       /* frames the port did not accept whole */
    uint32_t commands_ok;      /* commands applied */
    uint32_t commands_refused; /* valid commands refused in the current state */
    uint8_t health_polls;      /* polls until the last window's health frame is sent (0: none) */
    bool health_sent;          /* a health frame is due at health_due_us (else: at the next) */
    uint64_t health_due_us;    /* no health frame before this estimate time */
    /* The last command answered, to answer a retry (the same sequence, type and payload: the
     * same bytes) again without applying it twice (docs/reference/telemetry-protocol.md,
     * "Retries"). */
    bool last_valid;
    uint8_t last_seq, last_type, last_result, last_length;
    int8_t last_error;
    uint8_t last_payload[TOF_LINK_COMMAND_MAX];
    uint32_t commands_repeated;                 /* retries answered without being applied again */
    const struct tof_link_storage_ops *storage; /* what storage does (NULL: no storage) */
    struct tof_record_store *records;  /* where `save` keeps the settings (NULL: nowhere) */
    struct tof_settings process_noise; /* the last accepted set-process-noise, for `save` */
    uint8_t record_state;              /* enum tof_record_state found at start, in status */
    uint8_t cal_state;                 /* enum tof_cal_state found at start, in status */
    struct tof_rezero rezero;          /* a re-zero collecting samples (wanted 0: none) */
    bool rezero_raw;                   /* the raw stream the user had before it */
    /* A `save` under way (its record written in steps across polls, tof_record_step): its
     * answer goes out once the new copy is in use. */
    bool save_pending;
    uint8_t save_seq;
    /* The calibration's age kept across resets (NULL: not kept; it then counts from each
     * boot), on storage pages the record's erases never run alongside. */
    struct tof_cal_age *cal_age;
    /* The temperature of the last estimate's window (its last row), which the status frame
     * reports while the unit runs. */
    bool temp_known;
    int16_t temp_cdeg;
};

/* Start a link over `serial`. */
void tof_link_init(struct tof_link *link, struct hal_serial serial);

/* Keep the settings in `store` (initialised with tof_record_init()) through `ops` (the
 * storage modules, &tof_link_storage: firmware/link_storage.h): the service's start applies the
 * saved ones (firmware/settings.h), `save` writes them. Call before the start. Without this
 * call the link has no storage: its storage commands are answered `no-storage`, and the
 * image links none of the storage code. */
void tof_link_set_records(struct tof_link *link, const struct tof_link_storage_ops *ops,
                          struct tof_record_store *store);

/* Keep the calibration's age in `age` (on the same storage as the records, other pages, and
 * booted with tof_cal_age_boot() for the record's calibration, tof_cal_tag(), before
 * tof_app_init(): its scan of the pages stays off the application's timeline): the service's
 * start hands that age to the estimator, each poll keeps it on storage, a new calibration
 * starts it at 0, and the status frame reports the age the estimator counts. Call after
 * tof_link_set_records() and before the start. */
void tof_link_set_cal_age(struct tof_link *link, struct tof_cal_age *age);

/* Attach the application the commands act on (after tof_app_init). */
void tof_link_bind(struct tof_link *link, struct tof_app *app);

/* Handle up to TOF_LINK_RX_PER_POLL received bytes: decode, apply, answer; send the last
 * window's health frame when it is due (see tof_link_output_ops). */
void tof_link_poll(struct tof_link *link);

/* Send a status frame (also the answer to a status request). */
void tof_link_send_status(struct tof_link *link);

/* Output ops sending estimates, raw samples and a health frame per window, at most one per
 * TOF_LINK_HEALTH_PERIOD_US (ctx: the link). The health frame goes out at the second
 * tof_link_poll() after the window's estimates, i.e. after the next main-loop iteration,
 * so the window's own iteration does not carry it too. */
extern const struct tof_output_ops tof_link_output_ops;

/* tof_app_main() service ops (ctx: the link): start binds it, applies the saved settings
 * (tof_settings_boot()) and sends a status frame, poll is tof_link_poll(). */
extern const struct tof_app_service_ops tof_link_service_ops;

#endif /* FIRMWARE_LINK_H */
