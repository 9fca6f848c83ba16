;;; miketalk: text -> wav + timed phones with Festival (a radio-phoneset voice).
;;;
;;; Run as `festival -b synthesize.scm`. Settings come in through environment
;;; variables; the user's text through files (one string datum each, read with readfp,
;;; never evaluated): it is only ever used as a string datum, never spliced into a
;;; Scheme expression, and a long text does not meet the environment's size limit.
;;;   MIKETALK_VOICE     the voice, one of the names allowed below
;;;   MIKETALK_OUT       a directory; chunk I is written as I.wav (RIFF) and
;;;                      I.phones (one "name end-seconds" line per Segment)
;;;   MIKETALK_CHUNKS    how many chunks of text there are
;;;   MIKETALK_OUT/I.txt chunk I's text as one Scheme string datum ("..." with \ and "
;;;                      escaped), I = 0 .. MIKETALK_CHUNKS - 1
;;;   MIKETALK_ENDS_I    optional: a file holding one list of numbers, chunk I's
;;;                      dictated Segment end times in seconds. When given, the
;;;                      text modules run up to Duration, the ends are set, and
;;;                      only then Int_Targets and Wave_Synth (re-synthesis).
;;;   MIKETALK_PLAN      optional: when set, every chunk is first run up to
;;;                      Duration and its predicted phones written as I.plan; then
;;;                      "miketalk: planned" is printed on stderr and one datum is
;;;                      read from stdin (the caller writes `go` once it has put
;;;                      any I.ends files it wants in MIKETALK_OUT); each chunk
;;;                      then gets those ends (if its I.ends exists) and is spoken.
;;;                      One Festival run instead of a synthesis and a re-synthesis.
;;;   MIKETALK_STEPS     optional: chunk by chunk instead (a sentence at a time): chunk I
;;;                      is planned (I.plan), "miketalk: planned I" printed on stderr,
;;;                      one datum read from stdin (`go`, once any I.ends is written),
;;;                      the chunk spoken (I.wav, I.phones) and "miketalk: spoken I"
;;;                      printed; then chunk I + 1 is planned while the caller uses I.

(define (miketalk-env name)
  (let ((v (getenv name)))
    ;; getenv's value is re-read when handed to Utterance; a fresh string is not
    (if v (string-append "" v) nil)))

(define (miketalk-voice)
  (let ((name (miketalk-env "MIKETALK_VOICE")))
    (cond
     ((equal? name "voice_kal_diphone") (voice_kal_diphone))
     ((equal? name "voice_ked_diphone") (voice_ked_diphone))
     ((equal? name "voice_cmu_us_slt_arctic_hts") (voice_cmu_us_slt_arctic_hts))
     (t (format stderr "miketalk: unsupported voice %s\n" name) (exit 3)))))

(define (miketalk-read-ends path)
  (let ((fd (fopen path "r")) (ends nil))
    (set! ends (readfp fd))
    (fclose fd)
    ends))

(define (miketalk-set-ends utt ends)
  (let ((segs (utt.relation.items utt 'Segment)))
    (if (not (equal? (length segs) (length ends)))
        (begin
          (format stderr "miketalk: %d durations for %d phones\n" (length ends) (length segs))
          (exit 4)))
    (mapcar (lambda (seg end) (item.set_feat seg "end" end)) segs ends)))

;;; voice_ked_diphone's synthesis splits every er into er + r (its diphones have er-r):
;;; the r it inserts belongs to no syllable. It is written as part of its er, so
;;; that the phones spoken are the phones planned.
(define (miketalk-inserted? seg)
  (and seg
       (string-equal (item.name seg) "r")
       (not (item.relation seg 'SylStructure))
       (item.prev seg)
       (string-equal (item.name (item.prev seg)) "er")))

(define (miketalk-write-phones utt path)
  (let ((fd (fopen path "w")))
    (mapcar
     (lambda (seg)
       (if (not (miketalk-inserted? seg))
           (format fd "%s %.6f\n" (item.name seg)
                   (item.feat (if (miketalk-inserted? (item.next seg)) (item.next seg) seg)
                              "end"))))
     (utt.relation.items utt 'Segment))
    (fclose fd)))

(define (miketalk-text-utt i)
  "Chunk I's text as a Text utterance (the text is a string datum, never code)."
  (let ((text (miketalk-read-ends (miketalk-out-path i "txt"))))
    (if (not (equal? (typeof text) 'string))
        (begin (format stderr "miketalk: chunk %d's text is not a string\n" i) (exit 5)))
    (eval (list 'Utterance 'Text text))))

(define (miketalk-out-path i suffix)
  (format nil "%s/%d.%s" (miketalk-env "MIKETALK_OUT") i suffix))

(define (miketalk-save utt i)
  (utt.save.wave utt (miketalk-out-path i "wav") 'riff)
  (miketalk-write-phones utt (miketalk-out-path i "phones")))

(define (miketalk-chunk i)
  (let ((utt (miketalk-text-utt i))
        (ends-file (miketalk-env (format nil "MIKETALK_ENDS_%d" i))))
    (if ends-file
        (begin
          (set! utt (miketalk-text-to-duration utt))
          (miketalk-set-ends utt (miketalk-read-ends ends-file))
          (set! utt (miketalk-wave utt)))
        (set! utt (utt.synth utt)))
    (miketalk-save utt i)))

;;; utt.synth split in two at Duration, hooks included: the kal voice's
;;; after_synth_hooks rescale the wave by 2.6, and a re-synthesis without them
;;; would come out that much quieter than the first synthesis.
(define (miketalk-text-to-duration utt)
  (set! utt (apply_hooks before_synth_hooks utt))
  (Initialize utt) (Text utt) (Token_POS utt) (Token utt) (POS utt) (Phrasify utt)
  (Word utt) (Pauses utt) (Intonation utt) (PostLex utt) (Duration utt)
  utt)

(define (miketalk-wave utt)
  (Int_Targets utt) (Wave_Synth utt)
  (apply_hooks after_synth_hooks utt))

(define (miketalk-plan-chunk i)
  (let ((utt (miketalk-text-to-duration (miketalk-text-utt i))))
    (miketalk-write-phones utt (miketalk-out-path i "plan"))
    utt))

(define (miketalk-speak-planned utts i)
  (if utts
      (let ((utt (car utts))
            (ends-file (miketalk-out-path i "ends")))
        (if (probe_file ends-file)
            (miketalk-set-ends utt (miketalk-read-ends ends-file)))
        (miketalk-save (miketalk-wave utt) i)
        (miketalk-speak-planned (cdr utts) (+ i 1)))))

(define (miketalk-plan-all i n)
  (if (< i n)
      (cons (miketalk-plan-chunk i) (miketalk-plan-all (+ i 1) n))
      nil))

(define (miketalk-planned n)
  (let ((utts (miketalk-plan-all 0 n)) (fd nil) (go nil))
    (format stderr "miketalk: planned\n")
    (set! fd (fopen "/dev/stdin" "r"))
    (set! go (readfp fd))
    (fclose fd)
    (if (not (equal? go 'go))
        (begin (format stderr "miketalk: not told to go\n") (exit 5)))
    (miketalk-speak-planned utts 0)))

;;; MIKETALK_STEPS: chunk I planned, told to go, spoken; then I + 1 (see the top)
(define (miketalk-step i fd)
  (let ((utt (miketalk-plan-chunk i)) (go nil) (ends-file (miketalk-out-path i "ends")))
    (format stderr "miketalk: planned %d\n" i)
    (set! go (readfp fd))
    (if (not (equal? go 'go))
        (begin (format stderr "miketalk: not told to go\n") (exit 5)))
    (if (probe_file ends-file)
        (miketalk-set-ends utt (miketalk-read-ends ends-file)))
    (miketalk-save (miketalk-wave utt) i)
    (format stderr "miketalk: spoken %d\n" i)))

(define (miketalk-steps n fd)
  (let ((i 0))
    (while (< i n)
      (miketalk-step i fd)
      (set! i (+ i 1)))))

(define (miketalk-chunks i n)
  (if (< i n)
      (begin (miketalk-chunk i) (miketalk-chunks (+ i 1) n))))

(miketalk-voice)
(cond
 ((miketalk-env "MIKETALK_STEPS")
  (miketalk-steps (parse-number (miketalk-env "MIKETALK_CHUNKS")) (fopen "/dev/stdin" "r")))
 ((miketalk-env "MIKETALK_PLAN")
  (miketalk-planned (parse-number (miketalk-env "MIKETALK_CHUNKS"))))
 (t (miketalk-chunks 0 (parse-number (miketalk-env "MIKETALK_CHUNKS")))))
